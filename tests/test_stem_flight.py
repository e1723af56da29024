"""Flight and landing of the stemmed top (mett.dynamics.flight with mett.dynamics.stem and
stemslip; docs/theory/flight.md#the-stemmed-top).

References are independent of mett's flight code: scipy's solve_ivp of the torque-free rigid
body with a ballistic centre of mass (Euler's equations in the lab frame) and its event location
on the heights of both spheres, energy balances, and the contact model's own run handed to the
backend (prepare_run / run_prepared) for stop_on_contact_loss=True.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mett
from mett.dynamics import stem
from mett.dynamics.simulation import SIMULATE_DEFAULTS, prepare_run, run_prepared
from mett.friction import Coulomb

FRIEDL = mett.presets.stemmed("friedl1997")
THESIS = mett.presets.get("rutstam2013").with_stem(radius=0.004, distance=0.026)
RTOL_REF = 1e-12  # solve_ivp's tolerance for the reference: errors ~1e-12 of each magnitude


def _spheres(top):
    """((R, l) of the ball, (r_s, l + l_s) of the stem) in mett's convention (3̂: G → ball)."""
    b = top.ball
    l = b.R * b.alpha
    return (b.R, l), (top.radius, l + top.distance)


def _reference(top, y0: np.ndarray, tau_end: float):
    """solve_ivp of r̈ = −g ẑ, L̇ = 0, 3̂̇ = ω × 3̂ (ω = I⁻¹(3̂) L) from the state ``y0`` (stemmed
    layout, on the sphere of its flag, the CM height and vertical velocity that contact's), with
    terminal events on the gap z_G + l_i 3̂_z − R_i of the ball and of the stem."""
    b = top.ball
    I1, I3, g = b.I1, b.I3, b.g
    spheres = _spheres(top)
    Rc, lc = spheres[round(y0[10])]
    e0 = y0[7:10] / np.linalg.norm(y0[7:10])
    Lvec = np.array(y0[4:7])

    def omega(e):
        return Lvec / I1 + (1.0 / I3 - 1.0 / I1) * float(Lvec @ e) * e

    z0 = np.concatenate(([y0[0], y0[1], Rc - lc * e0[2]],
                         [y0[2], y0[3], -lc * np.cross(omega(e0), e0)[2]], e0))  # fmt: skip

    def rhs(t, z):
        e = z[6:9]
        return np.concatenate((z[3:6], [0.0, 0.0, -g], np.cross(omega(e), e)))

    def gap(i):
        R_i, l_i = spheres[i]

        def ev(t, z):
            return z[2] + l_i * z[8] - R_i if t > 1e-9 else 1.0  # not the contact at t = 0

        ev.terminal, ev.direction = True, -1.0
        return ev

    sol = solve_ivp(rhs, (0.0, tau_end), z0, method="DOP853", rtol=RTOL_REF, atol=1e-16,
                    dense_output=True, events=[gap(0), gap(1)])  # fmt: skip
    return sol, spheres


def _first_flight(top, state, t_end):
    traj = mett.simulate(top, state, t_end=t_end, t_eval=np.linspace(0.0, t_end, 401))
    sw = traj.records["switches"]
    assert sw[0].reason == "lift-off" and sw[0].t == 0.0 and sw[1].reason == "touchdown"
    return traj, sw[1]


@pytest.mark.parametrize(
    ("dtheta", "thetadot", "lands_on"),
    [(-0.05, 80.0, "stem"), (+0.05, -40.0, "ball")],
    ids=["ball-to-stem", "stem-to-ball"],
)
def test_flight_and_touchdown_match_an_independent_integration(dtheta, thetadot, lands_on):
    """A start whose contact force is negative flies at once: its states, gaps, touchdown time
    and the sphere it lands on equal solve_ivp's free rigid body with event location on both
    spheres' heights; the landing leaves the new contact's normal velocity 0 (inelastic)."""
    state = mett.State(theta=FRIEDL.touchdown_angle + dtheta, thetadot=thetadot)
    traj, td = _first_flight(FRIEDL, state, 0.002)
    assert td.after == lands_on and td.before == "flight"
    sol, spheres = _reference(FRIEDL, traj.states[:, 0], 0.01)
    hit = [k for k in (0, 1) if sol.t_events[k].size]
    assert len(hit) == 1 and ("ball", "stem")[hit[0]] == lands_on
    # event located to rtol 1e-12 of gaps ~1 mm moving at ≳ 1 cm/s: time error ≪ 1e-9 s
    assert abs(sol.t_events[hit[0]][0] - td.t) < 1e-9
    fly = (traj.contact == "none") & (traj.t < td.t)
    assert fly.sum() >= 5
    z = sol.sol(traj.t[fly])
    Y = traj.states[:, fly]
    scale_x = np.max(np.abs(z[0:2])) + spheres[1][1]
    assert np.allclose(Y[0:2], z[0:2], rtol=0.0, atol=1e-9 * scale_x)
    assert np.allclose(Y[7:10], z[6:9], rtol=0.0, atol=1e-9)
    assert np.allclose(Y[4:7], traj.states[4:7, :1], rtol=0.0, atol=0.0)  # L constant in flight
    gaps = np.array([z[2] + l_i * z[8] - R_i for R_i, l_i in spheres])
    assert np.allclose(traj.gap[fly], gaps.min(axis=0), rtol=0.0, atol=1e-9 * spheres[1][1])
    # the landing's jump: from the flight (flag of the sphere it left) onto the sphere that landed
    before, after = traj.records["jumps"][1]
    assert round(after[10]) == ("ball", "stem").index(lands_on) != round(before[10])


def test_flight_conserves_energy_and_landings_lose_it():
    """E never rises over a stemmed run with flights (error budget 100·rtol·E0 per sample) and
    is constant in each flight to rounding; every landing loses energy (E after ≤ E in flight)."""
    state = mett.State(theta=FRIEDL.touchdown_angle + 0.1, thetadot=-80.0)
    traj = mett.simulate(FRIEDL, state, t_end=0.05, rtol=1e-10)
    E = traj.E
    assert traj.status == "completed" and (traj.contact == "none").any()
    assert np.all(np.diff(E) <= 100 * 1e-10 * E[0])
    sw = [s for s in traj.records["switches"] if s.reason == "touchdown"]
    assert len(sw) >= 2
    for s in sw:
        fl = (traj.contact == "none") & (traj.t < s.t)
        Ef = E[fl][-1]
        i = np.searchsorted(traj.t, s.t)
        assert np.all(np.abs(E[fl][-3:] - Ef) <= 1e-12 * E[0])  # free flight: E constant
        assert E[i] <= Ef + 1e-12 * E[0]


def test_a_stemmed_run_that_lost_contact_now_completes_and_stop_is_bit_for_bit():
    """The thesis body with a stem at high spin (viscous law) lost contact at 4.96 s; it now
    hops on and completes. With stop_on_contact_loss=True the run is the contact model's run
    handed to the backend (prepare_run, run_prepared), bit for bit, and the flying run's
    samples before the lift-off are the same."""
    state = mett.State(theta=0.1, omega3=300.0)
    kw = {k: v for k, v in SIMULATE_DEFAULTS.items() if k not in ("stop_on_contact_loss", "model")}
    ref = run_prepared(prepare_run(THESIS.ball, state, 5.05, model=stem.MODEL,
                                   stem_radius=THESIS.radius, stem_distance=THESIS.distance,
                                   **kw))  # fmt: skip
    old = mett.simulate(THESIS, state, t_end=5.05, stop_on_contact_loss=True)
    assert old.status == ref.status == "contact_lost"
    assert old.t_contact_lost == ref.t_contact_lost
    assert np.array_equal(old.t, ref.t) and np.array_equal(old.states, ref.states)
    new = mett.simulate(THESIS, state, t_end=5.05)
    assert new.status == "completed" and "flight" in new.message
    assert new.t_contact_lost == old.t_contact_lost
    before = new.t < old.t_contact_lost
    assert np.array_equal(new.t[before], old.t[old.t < old.t_contact_lost])
    assert np.array_equal(new.states[:, before], old.states[:, old.t < old.t_contact_lost])
    assert set(new.contact[~before]) >= {"none", "ball"}
    assert np.all(new.gn_ball[new.contact == "none"] == 0.0)
    assert np.all(np.diff(new.E) <= 100 * SIMULATE_DEFAULTS["rtol"] * new.E[0])


def test_the_dry_stemmed_model_flies():
    """The thesis body with a stem under Coulomb–Contensou lost contact at 0.657 s; it now flies
    and lands with the dry impulse (energy never rises)."""
    state = mett.State(theta=0.1, omega3=155.0)
    law = Coulomb(0.3, contensou_radius=5e-4)
    old = mett.simulate(THESIS, state, t_end=0.75, friction=law, stop_on_contact_loss=True)
    assert old.status == "contact_lost" and 0.6 < old.t_contact_lost < 0.7
    new = mett.simulate(THESIS, state, t_end=0.75, friction=law)
    assert new.model == "stemmed-coulomb-contensou"
    assert new.status == "completed" and new.t_contact_lost == old.t_contact_lost
    reasons = [s.reason for s in new.records["switches"]]
    assert "lift-off" in reasons and "touchdown" in reasons
    assert (new.contact == "none").any()
    assert np.all(np.diff(new.E) <= 100 * SIMULATE_DEFAULTS["rtol"] * new.E[0])
