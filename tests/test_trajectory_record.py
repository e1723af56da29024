"""The Trajectory as a record made once: extras and records returned by the models, stored and
saved generically; the dense outputs' one protocol; Status and success; rtol, atol, t_end and
ψ(t) kept in the file (format 3); files of format 2 written by an older mett still load."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import quad, solve_ivp

import mett
from mett import State, Trajectory, presets
from mett.dynamics import MODELS, dense
from mett.dynamics._status import Status
from mett.friction import Coulomb

DATA = Path(__file__).parent / "data"
START = State(theta=0.1, omega3=155.0)
_STEMMED = mett.TippeTop(m=0.006, R=0.015, alpha=0.2, I1=8e-7, I3=7e-7, mu=0.3).with_stem(
    radius=0.005, distance=0.016
)
_NEAR_TOUCHDOWN = State(theta=2.15, thetadot=2.0, phidot=110.0, omega3=-76.0, nu_y=0.16)


@pytest.fixture(scope="module")
def top():
    return presets.get("rutstam2013")


@pytest.fixture(scope="module")
def stemmed_coulomb():
    return mett.simulate(_STEMMED, _NEAR_TOUCHDOWN, 0.07, friction=Coulomb(0.3))


# --- files of format 2, written by mett before this format (tests/data/README.md) -------------
def _raw(path: Path) -> tuple[dict, dict]:
    with np.load(path, allow_pickle=False) as data:
        entries = {k: np.array(data[k]) for k in data.files}
    return json.loads(str(entries.pop("mett_trajectory"))), entries


@pytest.mark.parametrize("name", ["format2_gliding", "format2_stemmed_coulomb"])
def test_a_format_2_file_of_an_older_mett_loads_with_its_extras_and_records(name):
    meta, entries = _raw(DATA / f"{name}.npz")
    assert meta["format_version"] == 2
    traj = Trajectory.load(DATA / f"{name}.npz")
    # every array as numpy reads it from the file, bit for bit
    assert np.array_equal(traj.t, entries["t"]) and np.array_equal(traj.states, entries["states"])
    for key in meta["series"]:
        assert np.array_equal(getattr(traj, key), entries[key]), key
    assert list(traj.extras) == meta["per_sample"]
    for key in meta["per_sample"]:
        assert np.array_equal(traj.extras[key], entries[f"extra_{key}"]), key
    assert len(traj.t_events) == meta["n_events"]
    # not recorded by format 2: None, and ψ computed from the dense output
    assert (traj.rtol, traj.atol, traj.t_end) == (None, None, None)
    assert traj.psi.shape == traj.t.shape and traj.psi[0] == 0.0
    assert traj.status == meta["status"] and traj.success
    if "switches" in meta:
        assert [sw.reason for sw in traj.switches] == [
            sw["fields"]["reason"] for sw in meta["switches"]
        ]
        assert np.array_equal(traj.touchdowns, entries["touchdowns"])
        assert len(traj.jumps) == meta["n_jumps"]
        assert np.array_equal(np.array([j[0] for j in traj.jumps]), entries["jumps_before"])
        assert traj.stopping_band == meta["stopping_band"]


def test_a_format_2_file_agrees_with_a_run_of_this_mett(stemmed_coulomb, tmp_path):
    old = Trajectory.load(DATA / "format2_stemmed_coulomb.npz")
    new = stemmed_coulomb
    # this mett records more (the double contact's gn_ball, gn_stem per sample and its
    # accumulations); what the older file has is a subset, in the same order
    assert [k for k in new.extra if k in old.extra] == list(old.extra)
    assert [k for k in new.records if k in old.records] == list(old.records)
    assert [s.reason for s in old.switches] == [s.reason for s in new.switches]
    # the same run at rtol = 1e-10: event times agree far inside 1e-6 s (10⁴ × rtol × t_end
    # covers the event location and any rounding of another machine)
    assert np.allclose(old.touchdowns, new.touchdowns, rtol=0, atol=1e4 * 1e-10 * 0.07)
    again = Trajectory.load(old.save(tmp_path / "v3.npz"))
    assert _raw(tmp_path / "v3.npz")[0]["format_version"] == 3
    assert repr(again.switches) == repr(old.switches) and again.extra == old.extra
    assert np.array_equal(again.psi, old.psi)


# --- rtol, atol, t_end ------------------------------------------------------------------------
def test_rtol_atol_and_the_requested_end_are_kept_and_saved(top, tmp_path):
    traj = mett.simulate(top, START, 0.05, rtol=1e-9, atol=1e-9)
    n = traj.states.shape[0]
    assert traj.rtol == 1e-9 and traj.t_end == 0.05
    assert traj.atol.shape == (n,) and np.all(traj.atol == 1e-9)
    default = mett.simulate(top, START, 0.02)
    assert default.rtol == 1e-10 and np.all(default.atol > 0) and default.atol.shape == (n,)
    loaded = Trajectory.load(traj.save(tmp_path / "tol.npz"))
    assert (loaded.rtol, loaded.t_end) == (1e-9, 0.05) and np.array_equal(loaded.atol, traj.atol)
    # a run that ends early keeps the end it was asked for
    lost = mett.simulate(top, State(theta=0.5, thetadot=-200.0, omega3=155.0), 1.0,
                        stop_on_contact_loss=True)  # fmt: skip
    assert lost.status == "contact_lost" and lost.t_end == 1.0 > lost.t_final


# --- psi ----------------------------------------------------------------------------------------
def _psi_reference(traj: Trajectory, model: str, t_end: float) -> np.ndarray:
    """ψ by an independent integration: the model's equations with ψ̇ appended, solved by
    scipy's DOP853 at rtol = 1e-12 (not along the run's dense output)."""
    mdl = MODELS[model]
    p = traj.params

    def rhs(t, z):
        y = z[:-1]
        psidot = float(mdl.derive(y.reshape(-1, 1), p)["psidot"][0])
        return np.append(mdl.rhs(t, y, p), psidot)

    z0 = np.append(traj.states[:, 0], 0.0)
    atol = np.append(1e-2 * traj.atol, 1e-12)
    sol = solve_ivp(rhs, (0.0, t_end), z0, method="DOP853", rtol=1e-12, atol=atol, t_eval=traj.t)
    assert sol.success
    return sol.y[-1]


def test_psi_agrees_with_an_independent_integration(top):
    t_end = 0.3
    traj = mett.simulate(top, START, t_end)
    ref = _psi_reference(traj, "gliding", t_end)
    assert abs(ref[-1]) > 10.0  # tens of turns' worth of spin: a real test
    # both solutions carry the integration error of the run (rtol = 1e-10 per step, grown over
    # ~10³ steps) on a ψ of size max|ψ|: 1e3 × rtol × max|ψ|
    tol = 1e3 * traj.rtol * np.max(np.abs(ref))
    assert np.max(np.abs(traj.psi - ref)) <= tol
    # ψ̇ = ω3 − φ̇ cos θ, not ω3: dropping the precession term would be far outside
    assert np.max(np.abs(np.cumsum(np.diff(traj.t) * traj.omega3[1:]) - ref[1:])) > 1e3 * tol


def test_psi_is_the_integral_of_psidot_along_the_dense_output_of_a_hybrid_run(stemmed_coulomb):
    traj = stemmed_coulomb
    mdl = MODELS[traj.model]

    def psidot(t):
        return float(mdl.derive(traj.states_at(t).reshape(-1, 1), traj.params)["psidot"][0])

    # adaptive quadrature (scipy's QUADPACK) with the switch times as break points
    breaks = [sw.t_event for sw in traj.switches]
    assert len(breaks) >= 3
    total, err = quad(psidot, traj.t[0], traj.t[-1], points=breaks, epsabs=1e-13, epsrel=0.0,
                      limit=1000)  # fmt: skip
    # QUADPACK's error estimate, plus the rounding of the cumulative sum over the pieces
    scale = np.max(np.abs(traj.psidot)) * traj.t_final
    assert abs(traj.psi[-1] - total) <= 10 * err + 1e3 * np.finfo(float).eps * scale
    assert traj.psi[0] == 0.0


# --- Status and success -------------------------------------------------------------------------
def test_status_is_one_str_enumeration_and_success_counts_completed_only(top, tmp_path):
    assert [s.value for s in Status] == ["completed", "contact_lost", "failed"]
    done = mett.simulate(top, START, 0.02)
    assert done.status is Status.COMPLETED and done.status == "completed" and done.success
    assert repr(done.status) == "'completed'" and f"{done.status}" == "completed"
    lost = mett.simulate(top, State(theta=0.5, thetadot=-200.0, omega3=155.0), 1.0,
                        stop_on_contact_loss=True)  # fmt: skip
    assert lost.status is Status.CONTACT_LOST and not lost.success
    failed = mett.simulate(top, State(theta=0.0, omega3=10.0), 1.0, model="gliding-euler")
    assert failed.status == Status.FAILED and not failed.success
    meta = _raw(failed.save(tmp_path / "f.npz"))[0]
    assert meta["status"] == "failed"
    assert Trajectory.load(tmp_path / "f.npz").status is Status.FAILED


# --- extras and records: returned by the models, stored generically ---------------------------
def test_every_run_is_the_same_record_whatever_its_model(stemmed_coulomb, top):
    # what a model adds is in extras/records, never set as attributes by its producers: every
    # run's own attributes are the same names (the derived series, cached, aside)
    from mett.friction import Viscous

    runs = [
        stemmed_coulomb,
        mett.simulate(top, START, 0.02),
        mett.simulate(top, START, 0.02, friction=Viscous(0.3)),
        mett.simulate(top, State.with_cm_at_rest(top, 0.1, 155.0), 0.1, friction=Coulomb(0.02)),
        mett.simulate(_STEMMED, _NEAR_TOUCHDOWN, 0.03),
    ]
    own = {*mett.dynamics.trajectory.SERIES, "psi"}
    names = [set(traj.__dict__) - own for traj in runs]
    assert all(n == names[0] for n in names[1:]), [n ^ names[0] for n in names]
    assert runs[2].extra == ("phase", "F_x", "F_y", "M_n")
    assert set(runs[3].records) == {"switches", "jumps", "stopping_band"}
    assert set(runs[4].extras) == {"phase", "contact", "gn_ball", "gn_stem"}
    assert "touchdowns" in runs[4].records


def test_a_trajectory_saves_extras_and_records_it_has_never_seen(top, tmp_path):
    base = mett.simulate(top, START, 0.02)
    n, k = base.t.size, base.states.shape[0]
    rng = np.random.default_rng(1)
    pairs = [(rng.normal(size=k), rng.normal(size=k)) for _ in range(3)]
    traj = Trajectory(
        t=base.t, states=base.states, model=MODELS["gliding"], top=top, params=base.params,
        solution=base._sol, status="completed", message="made by hand",
        extras={"slip_angle": rng.normal(size=n), "label": np.array(["a", "bc"] * (n // 2)
                                                                     + ["a"] * (n % 2))},
        records={"count": 3, "curve": rng.normal(size=(4, 2)), "pairs": pairs,
                 "events": [(0.01, "up", "down")], "none_yet": []},
        rtol=1e-10, atol=base.atol, t_end=0.02,
    )  # fmt: skip
    assert traj.slip_angle is traj.extras["slip_angle"] and traj.count == 3
    loaded = Trajectory.load(traj.save(tmp_path / "new.npz"))
    for name in traj.extras:
        assert np.array_equal(loaded.extras[name], traj.extras[name]), name
    assert loaded.count == 3.0 and np.array_equal(loaded.curve, traj.curve)
    assert all(np.array_equal(a, b) for p, q in zip(loaded.pairs, pairs, strict=True)
               for a, b in zip(p, q, strict=True))  # fmt: skip
    assert loaded.events == [(0.01, "up", "down")] and loaded.none_yet == []
    with pytest.raises(ValueError, match="extra series 'states' would hide"):
        base.with_extras({"states": np.zeros(n)})
    with pytest.raises(TypeError, match="record 'bad' of type object cannot be saved"):
        Trajectory.load(traj.save(tmp_path / "ok.npz")).__class__(
            t=base.t, states=base.states, model=MODELS["gliding"], top=top, params=base.params,
            solution=base._sol, status="completed", message="", records={"bad": object()},
        ).save(tmp_path / "bad.npz")  # fmt: skip
    assert not (tmp_path / "bad.npz").exists()


# --- the dense outputs' one protocol --------------------------------------------------------------
def test_every_dense_output_round_trips_through_arrays_and_truncates(top, stemmed_coulomb):
    runs = {
        "dop853": mett.simulate(top, START, 0.05),
        "taylor": mett.simulate(top, START, 0.05, backend="taylor"),
        "rk45": mett.simulate(top, START, 0.05, backend="scipy", method="RK45"),
        "segments": stemmed_coulomb,
    }
    for name, traj in runs.items():
        sol = traj._sol
        desc, arrays = dense.to_arrays(sol, lambda ph, ts, Y: np.zeros_like(Y))
        back = dense.from_arrays(json.loads(json.dumps(desc)), arrays)
        tt = np.linspace(traj.t[0], traj.t[-1], 257)
        if name != "rk45":  # the solver's own polynomials: bit for bit
            assert np.array_equal(back(tt), sol(tt)), name
        else:  # Hermite data through the steps (slopes given as 0 here: exact at the steps)
            assert np.allclose(back(sol.ts), sol(sol.ts), rtol=0, atol=1e-15), name
        cut = 0.5 * (traj.t[0] + traj.t[-1])
        short = dense.truncate(back, cut)
        assert short.t_max == cut or float(np.asarray(short.ts)[-1]) == cut, name
        early = tt[tt <= cut]
        scale = np.max(np.abs(traj.states), axis=1, keepdims=True)
        assert np.all(np.abs(short(early) - back(early)) <= 1e-12 * scale), name
    assert isinstance(dense.ConstantSolution(0.0, np.ones(3)), dense.DenseSolution)
