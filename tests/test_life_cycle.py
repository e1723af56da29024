"""Long lives of real tops under every friction law (tools/life_matrix.py; docs/theory/stem.md#long-runs).

A representative subset of the stress matrix runs by default, the full matrix is ``slow``. Every
run must complete, with each change of contact a located switch with its reason, the energy never
rising beyond the integration error, no pulling normal force and no sphere inside the table.
References are independent of mett: the invariants themselves, and for the defect fixed here
(a contact that needs a pulling force right after an impact) the free motion's acceleration of
the new contact point from Newton–Euler, written out in the test.
"""

from __future__ import annotations

import importlib.util
import pathlib

import numpy as np
import pytest

import mett
from mett.dynamics import stem
from mett.dynamics.simulation import SIMULATE_DEFAULTS
from mett.friction import Coulomb, RegularisedCoulomb, Viscous
from mett.stem import StemmedTop

_SPEC = importlib.util.spec_from_file_location(
    "life_matrix", pathlib.Path(__file__).resolve().parents[1] / "tools" / "life_matrix.py"
)
life_matrix = importlib.util.module_from_spec(_SPEC)
_SPEC.loader.exec_module(life_matrix)

TOPS = life_matrix.tops()
LAWS = life_matrix.laws()
RTOL = SIMULATE_DEFAULTS["rtol"]
# E is integrated to rtol per step; between two samples its error is a few rtol × |E|: 100 rtol × |E|
# is the budget the stem and flight tests use (tests/test_stem_flight.py)
E_BUDGET = 100.0 * RTOL
# a lift-off is located where the force crosses 0: the sample there is 0 to the event tolerance
# (rtol of the force's scale m g)
GN_FLOOR = -1e-9
# a change of contact fires when the other sphere's clearance reaches −SWITCH_OFFSET R; the event
# is located to rtol of lengths ~R, so no sample lies deeper than a few SWITCH_OFFSET R
PEN_MAX = 10.0 * stem.SWITCH_OFFSET
REASONS = {"touchdown", "landing", "lift-off", "accumulation", "closure", "ball lifts off",
           "stem lifts off", "stop", "cone", "reversal"}  # fmt: skip


def check_life(top, traj) -> None:
    """The invariants of a whole life: status, switches, energy, forces, no penetration."""
    assert traj.status == "completed", traj.message
    ball = top.ball if isinstance(top, StemmedTop) else top
    mg = ball.m * ball.g
    contact = getattr(traj, "contact", None)
    switches = getattr(traj, "switches", None) or []
    for sw in switches:
        assert sw.reason in REASONS, sw
    if contact is not None:
        contact = np.asarray(contact)
        t_sw = np.array([sw.t for sw in switches])
        for i in np.flatnonzero(contact[1:] != contact[:-1]):
            # every change of contact between two samples is a located switch between them
            assert np.any((t_sw >= traj.t[i]) & (t_sw <= traj.t[i + 1])), (traj.t[i], contact[i])
    E = np.asarray(traj.E, dtype=float)
    assert np.all(np.diff(E) <= E_BUDGET * np.max(np.abs(E)))
    assert np.min(traj.gn) >= GN_FLOOR * mg
    if contact is not None and getattr(traj, "gn_ball", None) is not None:
        both = contact == "both"
        if both.any():
            assert np.min(traj.gn_ball[both]) >= GN_FLOOR * mg
            assert np.min(traj.gn_stem[both]) >= GN_FLOOR * mg
    assert life_matrix.penetration(top, traj) <= PEN_MAX


# (top, law, θ0, spin factor, start): each kind of life once — the stem reached through an
# accumulation and a double contact (friedl, thesis-stem), hops on the ball (thesis), a stem
# touchdown that lifts off at once (thesis-stem Contensou at 5×), dry rolling (cohen), and the
# stemmed top under the regularised law (an accumulation and a double contact; hops from the
# stem with the regularised landing)
FAST = [
    ("friedl", "contensou", 0.1, 1.5, "cm"),
    ("friedl", "viscous", 0.5, 1.5, "cm"),
    ("thesis-stem", "viscous", 0.1, 1.5, "nu0"),
    ("thesis-stem", "contensou", 0.05, 5.0, "cm"),
    ("thesis", "viscous", 0.1, 5.0, "cm"),
    ("thesis", "regularised", 0.5, 1.5, "nu0"),
    ("thesis-stem", "regularised", 0.1, 1.5, "nu0"),
    ("friedl", "regularised", 0.5, 1.5, "cm"),
    ("cohen", "coulomb", 0.1, 5.0, "nu0"),
]


def _run(tname, lname, theta0, factor, start, t_end=8.0):
    top = TOPS[tname]
    w3 = round(factor * mett.thresholds.min_spin_for_inversion(life_matrix.ball_of(top), theta0), 1)
    state = life_matrix.start_state(top, theta0, w3, start)
    return top, mett.simulate(top, state, t_end=t_end, friction=LAWS[lname])


@pytest.mark.parametrize("case", FAST, ids=["-".join(map(str, c)) for c in FAST])
def test_a_life_completes_with_its_invariants(case):
    top, traj = _run(*case)
    check_life(top, traj)


def _free_acceleration(top, y, sphere: int) -> float:
    """ḧ (m/s²) of the lowest point of a sphere (0 ball, 1 stem) of the stemmed top in free motion
    from the viscous stemmed state ``y`` (x, y, vx, vy, L, 3̂, flag): z̈_G = −g and, with L
    constant and L·3̂ constant, ω = L/I1 + (1/I3 − 1/I1)(L·3̂)3̂, 3̂̇ = ω × 3̂,
    3̂̈ = ω̇ × 3̂ + ω × 3̂̇ with ω̇ = (1/I3 − 1/I1)(L·3̂) 3̂̇; h = z_G + l_i 3̂_z − R_i."""
    b = top.ball
    l_i = b.alpha * b.R + (top.distance if sphere == 1 else 0.0)
    L, e = np.asarray(y[4:7]), np.asarray(y[7:10]) / np.linalg.norm(y[7:10])
    k = (1.0 / b.I3 - 1.0 / b.I1) * float(L @ e)
    w = L / b.I1 + k * e
    de = np.cross(w, e)
    dde = np.cross(k * de, e) + np.cross(w, de)
    return -b.g + l_i * dde[2]


@pytest.mark.parametrize(
    "law", [Viscous(0.3), Coulomb(0.3), Coulomb(0.3, contensou_radius=5e-4),
            RegularisedCoulomb(0.3, eps=1e-2)],
    ids=["viscous", "coulomb", "contensou", "regularised"],
)  # fmt: skip
def test_a_touchdown_that_needs_a_pulling_force_lifts_off(law):
    """Defect: after the stem's touchdown impact the stem's contact would need a pulling force
    (g_n < 0), and the stem phase ran on with it, g_n ≈ −0.08 m g and E rising by ~5e-4 of itself
    (before: no lift-off, min g_n < 0). Now the new contact lifts off at the impact: a "lift-off"
    switch at the touchdown's time, a flight, and every invariant of a life."""
    top = TOPS["friedl"]
    state = mett.State(
        theta=2.44, thetadot=13.0, phidot=-50.0, omega3=-45.0
    )  # rocking onto the stem
    traj = mett.simulate(top, state, t_end=0.01, friction=law)
    sw = traj.switches
    assert (sw[0].reason, sw[0].before[:4], sw[0].after[:4]) == ("touchdown", "ball", "stem")
    assert sw[1].reason == "lift-off" and sw[1].t == sw[0].t
    assert traj.t_contact_lost == sw[0].t
    check_life(top, traj)
    if isinstance(law, Viscous):  # independent: the free motion leaves the table at the stem
        after = traj.records["jumps"][0][1]
        assert round(after[10]) == 1
        assert _free_acceleration(top, after, 1) > 0.0
    # stop_on_contact_loss=True now ends there, instead of running on with the pulling force
    stop = mett.simulate(top, state, t_end=0.01, friction=law, stop_on_contact_loss=True)
    assert stop.status == "contact_lost" and stop.t_contact_lost == sw[0].t


ALL = [
    (t, law, th, f, s)
    for t in life_matrix.tops()
    for law in life_matrix.laws()
    for th in life_matrix.THETA0
    for f in life_matrix.SPIN_FACTORS
    for s in life_matrix.STARTS
]


@pytest.mark.slow
@pytest.mark.parametrize("case", ALL, ids=["-".join(map(str, c)) for c in ALL])
def test_the_full_matrix(case):
    top, traj = _run(*case)
    check_life(top, traj)


# the gap of a lift-off of the thesis body under Coulomb–Contensou (θ0 = 0.5, ω3 = 465.1 rad/s,
# contact point at rest; at t = 0.98313 s): (h0, ḣ0, g, l, Ω, u_z, v_z), M4, t0 — inputs
_GRAZE = ((0.0, 0.0, 9.82, 0.006, 492.21945682007265, -0.006755269561715127,
           -0.009161001168075661), 4008831.6666319156, 0.9831252266566536)  # fmt: skip


def _gap_mp(args, tau):
    """h(τ) at 50 digits: h0 + ḣ0 τ − g τ²/2 + l [u_z (cos Ωτ − 1) + v_z (sin Ωτ − Ωτ)]."""
    import mpmath

    with mpmath.workdps(50):
        h0, hd0, g, l, W, uz, vz = (mpmath.mpf(x) for x in args)
        t = mpmath.mpf(tau)
        w = W * t
        return (
            h0 + hd0 * t - g * t * t / 2 + l * (uz * (mpmath.cos(w) - 1) + vz * (mpmath.sin(w) - w))
        )


def test_a_lift_off_whose_gap_dips_by_rounding_is_a_real_flight():
    """Defect: at a lift-off located a rounding error early (ḧ(0) = −1.8e-15 m/s², h⃛ > 0) the gap
    dips below 0 until τ* = −2ḧ/h⃛ ≈ 2e-18 s and then rises; the march computed h(τ*) = 0 by
    cancellation and returned τ* as the touchdown: a zero-length hop, the contact needing a pull
    again, 10 000 flights at one instant and status "failed" (before). Now the touchdown is the
    first root of the rising gap, checked against the gap at 50 digits."""
    from mett.dynamics import _hop
    from mett.dynamics.flight import Hop

    args, M4, t0 = _GRAZE
    tau = _hop.touchdown(*args, M4, t0, 1.0)
    hop = Hop.__new__(Hop)  # the Python reference march on the same gap
    hop.h0, hop.hd0, hop.g, hop.l, hop.Omega = args[0], args[1], args[2], args[3], args[4]
    hop.u, hop.v, hop.M4, hop.t0 = (
        np.array([0.0, 0.0, args[5]]),
        np.array([0.0, 0.0, args[6]]),
        M4,
        t0,
    )
    assert hop.touchdown_reference(1.0) == pytest.approx(tau, rel=1e-12)
    assert tau > 1e-6  # not the dip's end, ~1e-18 s
    grid = np.linspace(tau * 1e-3, tau * (1.0 - 1e-6), 200)
    assert all(_gap_mp(args, x) > 0 for x in grid)  # the gap is open before the touchdown
    assert abs(_gap_mp(args, tau)) < 1e-12 * args[3]  # and closes at it
    assert _gap_mp(args, tau * (1.0 + 1e-6)) < 0
    # the run that ground through 10 000 flights at t = 0.98313 s goes on
    top = TOPS["thesis"]
    traj = mett.simulate(
        top, mett.State(theta=0.5, omega3=465.1), t_end=1.0, friction=LAWS["contensou"]
    )
    check_life(top, traj)


def test_a_normal_force_that_dips_below_zero_within_one_step_is_a_lift_off():
    """Defect: under Coulomb–Contensou the thesis body's g_n dips below 0 for ~1.5 ms near
    t = 1.6229 s, shorter than a step at rtol = 1e-10: both ends of the step had g_n > 0, the
    lift-off was missed and the contact pulled the top down (E rose by 1e-7 of itself between two
    samples, min g_n 0.0018 N). The dry models' contact_lost events are now grazing events (the
    compiled DOP853 looks for an interior minimum of g_n over each step): the run lifts off there,
    as the same run at rtol = 1e-12, whose steps resolve the dip, does."""
    top = TOPS["thesis"]
    state = mett.State.with_cm_at_rest(top, theta=0.5, omega3=465.1)
    traj = mett.simulate(top, state, t_end=1.65, friction=LAWS["contensou"])
    check_life(top, traj)
    fine = mett.simulate(top, state, t_end=1.65, friction=LAWS["contensou"], rtol=1e-12)
    lift = [sw.t for sw in traj.switches if sw.reason == "lift-off"]
    lift_fine = [sw.t for sw in fine.switches if sw.reason == "lift-off"]
    assert len(lift) == len(lift_fine)
    # the two runs differ by their integration errors (rtol 1e-10 over ~2000 steps of a motion
    # whose nutation period is ~13 ms): their lift-offs agree to 1e-5 s
    assert np.allclose(lift, lift_fine, rtol=0.0, atol=1e-5)


@pytest.mark.parametrize("eps", [1e-2, 1e-5])
def test_the_regularised_landing_impulse_matches_radau(eps):
    """Defect (a stall): every regularised landing integrated its impulse with scipy's Radau,
    ~140 steps and 0.1-0.5 s of CPU per landing, so a hopping run took minutes (the thesis body
    at 1546 rad/s: more than 60 s for 8 s). It now uses LSODA. Checked against Radau at
    rtol 1e-12 (an independent method and tolerance) on a landing that is stiff (ε = 1e-5 m/s:
    μ|W|/ε × p ~ 1e5) and one that is not; both agree to the 1e-10 tolerance's error, 1e-8."""
    from mett.dynamics import flight

    rng = np.random.default_rng(7)
    A = rng.normal(size=(3, 3))
    W = 30.0 * (A @ A.T + 3.0 * np.eye(3))  # N s → m/s: a body of a few grams
    v0 = np.array([0.05, -0.02, -0.5])  # |v_t| passes through 0 during the impact

    def tangential(vx, vy):
        k = -0.3 / np.sqrt(vx * vx + vy * vy + eps * eps)
        return k * vx, k * vy

    P = flight.regularised_impulse(v0, W, 0.3, eps)
    ref = stem.compression_impulse(v0, W, tangential, "Radau", 1e-12, 1e-16)
    assert np.allclose(P, ref, rtol=0.0, atol=1e-8 * abs(ref[2]))
    assert abs((v0 + W @ P)[2]) <= 1e-9 * abs(v0[2])  # compression ended
    assert float(v0 @ P + 0.5 * P @ (W @ P)) < 0.0  # the landing dissipates
