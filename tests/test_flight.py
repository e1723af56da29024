"""Flight and landing of the ball top (mett.dynamics.flight; docs/theory/flight.md).

References are independent of mett's flight code: scipy's solve_ivp of the torque-free rigid
body with a ballistic centre of mass (Euler's equations in the lab frame), its event location
for the touchdown, the closed-form limit of a geometric hop sequence, and energy balances.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import mett
from mett.dynamics import flight
from mett.dynamics.simulation import prepare_run, run_prepared

TOP = mett.presets.get("rutstam2013")
M, R, L, I1, I3, G = TOP.m, TOP.R, TOP.R * TOP.alpha, TOP.I1, TOP.I3, TOP.g
BODY = (M, R, L, I1, I3, G)
EPS = np.finfo(float).eps


def _launch_state() -> np.ndarray:
    """A generic gliding-layout state: tilted axis, spin and wobble, CM moving sideways."""
    e = np.array([math.sin(0.7) * math.cos(0.3), math.sin(0.7) * math.sin(0.3), math.cos(0.7)])
    w = 40.0 * e + np.array([3.0, -5.0, 2.0])
    Lvec = I1 * w + (I3 - I1) * float(w @ e) * e
    return np.array([0.01, -0.02, 0.3, -0.1, *Lvec, *e])


def _reference(y: np.ndarray, gap_rate: float, tau_end: float, **kw):
    """solve_ivp of r̈ = −g ẑ, L̇ = 0, 3̂̇ = ω × 3̂ with ω = I⁻¹(3̂) L (rtol 1e-12)."""
    e0 = y[7:10] / np.linalg.norm(y[7:10])
    Lvec = y[4:7]

    def omega(e):
        return Lvec / I1 + (1.0 / I3 - 1.0 / I1) * float(Lvec @ e) * e

    zG0 = R - L * e0[2]
    vz0 = -L * np.cross(omega(e0), e0)[2] + gap_rate

    def rhs(t, z):
        e = z[6:9]
        return np.concatenate((z[3:6], [0.0, 0.0, -G], np.cross(omega(e), e)))

    z0 = np.concatenate(([y[0], y[1], zG0], [y[2], y[3], vz0], e0))
    return solve_ivp(rhs, (0.0, tau_end), z0, method="DOP853", rtol=1e-12, atol=1e-15,
                     dense_output=True, **kw)  # fmt: skip


def test_flight_matches_an_independent_rigid_body_integration():
    """(a) State, gap and the dense output's Taylor polynomials of a hop equal solve_ivp's
    torque-free body to its tolerance (rtol 1e-12: errors ~1e-12 of each magnitude)."""
    y = _launch_state()
    hop = flight.Hop(y, 0.0, BODY, gap=0.0, gap_rate=0.05)
    tau = np.linspace(0.0, 0.01, 23)
    ref = _reference(y, 0.05, 0.01).sol(tau)
    mine = hop.state(tau)
    assert np.allclose(mine[7:10], ref[6:9], rtol=0, atol=1e-10)
    assert np.allclose(mine[0:2], ref[0:2], rtol=0, atol=1e-12)
    h_ref = ref[2] + L * ref[8] - R
    h = np.array([hop.gap(float(t))[0] for t in tau])
    assert np.allclose(h, h_ref, rtol=0, atol=1e-12)
    dense = hop.dense(0.01, lambda Y: Y)
    assert np.allclose(dense(tau + 0.0)[7:10], ref[6:9], rtol=0, atol=1e-10)
    # a sign error in the precession would move 3̂ by ~Ω τ ≈ 1 rad: far outside the tolerance
    assert hop.Omega * 0.01 > 0.3


def test_touchdown_matches_an_independent_event_location():
    """(b) The touchdown time equals the first zero of z_G + l 3̂_z − R located by solve_ivp's
    events on the reference (both to ~1e-12 s: δh / |ḣ| with δh ~ 1e-14 m)."""
    y = _launch_state()
    hop = flight.Hop(y, 0.0, BODY, gap=0.0, gap_rate=0.05)

    def gap(t, z):
        return z[2] + L * z[8] - R

    gap.terminal, gap.direction = True, -1.0
    ref = _reference(y, 0.05, 1.0, events=gap)
    t_ref = float(ref.t_events[0][0])
    tau = hop.touchdown(1.0)
    assert tau == pytest.approx(t_ref, abs=1e-10)
    # the wobble makes the gap non-monotone: a first touchdown well before the ballistic one
    assert tau < 2 * 0.05 / G


def test_thesis_body_at_high_spin_completes_and_inverts():
    """(d) The thesis body under the viscous law at ω3 = 300 rad/s loses contact before θ = π/2
    (status "contact_lost" with stop_on_contact_loss=True); by default it flies, lands and
    inverts: "completed", θ crosses π/2."""
    state = mett.State(theta=0.1, omega3=300.0)
    old = mett.simulate(TOP, state, t_end=9.0, stop_on_contact_loss=True)
    assert old.status == "contact_lost" and not old.crossings(math.pi / 2).size
    traj = mett.simulate(TOP, state, t_end=9.0)
    assert traj.status == "completed"
    assert traj.crossings(math.pi / 2).size
    assert traj.t_contact_lost == old.t_contact_lost
    reasons = [s.reason for s in traj.switches]
    assert reasons[0] == "lift-off" and "touchdown" in reasons
    flying = traj.contact == "none"
    assert flying.any() and np.all(traj.gn[flying] == 0.0) and np.all(traj.gap[flying] >= 0.0)
    assert np.all(traj.gap[~flying] == 0.0)
    _check_energy(traj)


def _check_energy(traj):
    """(c) E never rises: per sample by at most the integration error (10 rtol E), constant in
    flight to rounding, and no landing raises it."""
    E = traj.E
    scale = float(np.max(np.abs(E)))
    assert np.max(np.diff(E)) <= 10 * traj.rtol * scale
    flying = traj.contact == "none"
    starts = np.flatnonzero(np.diff(flying.astype(int)) != 0) + 1
    for seg in np.split(np.arange(E.size), starts):
        if flying[seg[0]] and seg.size > 1:
            assert np.ptp(E[seg]) <= 1e3 * EPS * scale
    for sw in traj.switches:
        if sw.reason == "touchdown":
            i = int(np.searchsorted(traj.t, sw.t))  # first sample after the landing
            assert E[i] <= E[i - 1] + 1e3 * EPS * scale


def test_stop_on_contact_loss_reproduces_the_old_run_bit_for_bit():
    """(e) stop_on_contact_loss=True is the contact model's run as before (the prepared run
    handed to the backend), and a run that never loses contact is unchanged by the default."""
    state = mett.State(theta=0.1, omega3=450.0)
    kw = {k: v for k, v in mett.dynamics.simulation.SIMULATE_DEFAULTS.items()
          if k != "stop_on_contact_loss"}  # fmt: skip
    ref = run_prepared(prepare_run(TOP, state, 6.0, **kw))
    new = mett.simulate(TOP, state, t_end=6.0, stop_on_contact_loss=True)
    assert new.status == ref.status == "contact_lost"
    assert new.t_contact_lost == ref.t_contact_lost
    assert np.array_equal(new.t, ref.t) and np.array_equal(new.states, ref.states)
    calm = mett.State(theta=0.1, omega3=155.0)
    a = mett.simulate(TOP, calm, t_end=1.0)
    b = mett.simulate(TOP, calm, t_end=1.0, stop_on_contact_loss=True)
    assert np.array_equal(a.states, b.states) and "contact" not in a.extras


def test_a_start_without_contact_force_flies_at_once(tmp_path):
    """(f) A fast fall at θ = 3 (g_n < 0 at t = 0) starts in flight; the run saves and loads."""
    state = mett.State(theta=3.0, thetadot=60.0, omega3=10.0)
    assert mett.simulate(TOP, state, t_end=0.2, stop_on_contact_loss=True).status == "contact_lost"
    traj = mett.simulate(TOP, state, t_end=0.2)
    assert traj.status == "completed"
    assert traj.switches[0].reason == "lift-off" and traj.switches[0].t == 0.0
    assert traj.contact[0] == "none" and traj.t_contact_lost == 0.0
    assert traj.gap.max() > 0.0
    _check_energy(traj)
    path = tmp_path / "hop.npz"
    traj.save(path)
    back = mett.Trajectory.load(path)
    assert np.array_equal(back.states, traj.states) and np.array_equal(back.gap, traj.gap)
    assert list(back.contact) == list(traj.contact)
    assert [(s.t, s.reason) for s in back.switches] == [(s.t, s.reason) for s in traj.switches]
    t = 0.5 * (traj.switches[0].t + traj.switches[1].t)
    assert back.at(t).theta == traj.at(t).theta


def test_accumulation_of_a_bouncing_sequence_has_its_analytic_limit():
    """(g) A ball bouncing with restitution e hops for d_k = d0 e^k: the detector finds the ratio
    e and the limit Σ_{k>n} d_k = d_n e/(1 − e) exactly; not with contact between hops or a
    non-geometric sequence."""
    e, d0 = 0.6, 2 * 0.5 / G
    d = [d0 * e**k for k in range(12)]
    ratio, rest = flight.accumulation(d, [0.0] * 12)
    assert ratio == pytest.approx(e, rel=1e-12)
    assert rest == pytest.approx(sum(d0 * e**k for k in range(12, 400)), rel=1e-12)
    assert flight.accumulation(d, [0.0] * 6 + [1e-3] * 6) is None
    assert flight.accumulation([d0 / (k + 1) for k in range(12)], [0.0] * 12) is None


def test_dry_laws_fly_and_land():
    """Coulomb–Contensou runs fly too: lift-offs, touchdowns, E never rising."""
    law = mett.friction.Coulomb(0.3, contensou_radius=5e-4)
    traj = mett.simulate(TOP, mett.State(theta=0.1, omega3=300.0), t_end=1.5, friction=law)
    assert traj.status == "completed"
    assert sum(s.reason == "touchdown" for s in traj.switches) >= 1
    assert set(np.unique(traj.phase)) <= {"sliding", "rolling", "flight"}
    _check_energy(traj)
    _check_transitions(traj)


@pytest.mark.parametrize(
    "law", [mett.friction.Coulomb(0.3), mett.friction.RegularisedCoulomb(0.3, 1e-3)]
)
def test_every_dry_law_lands(law):
    """Coulomb and regularised Coulomb from a start in flight: touchdowns, E never rising."""
    state = mett.State(theta=3.0, thetadot=60.0, omega3=10.0)
    traj = mett.simulate(TOP, state, t_end=0.2, friction=law)
    assert traj.status == "completed", traj.message
    assert sum(s.reason == "touchdown" for s in traj.switches) >= 2
    _check_energy(traj)
    _check_transitions(traj)


def test_regularised_landing_impulse():
    """The regularised impact ends compression (v_z = 0), dissipates (ΔT = v0·P + ½ P·W P < 0,
    W the contact's inverse effective mass), is the frictionless −v_z/W_zz ẑ at μ = 0 and the
    viscous impulse of coefficient μ/ε where |v_t| ≪ ε (law error (v_t/ε)² ~ 1e-11, LSODA at
    rtol 1e-10: agreement 1e-8)."""
    rng = np.random.default_rng(3)
    A = rng.normal(size=(3, 3))
    W = A @ A.T + 3 * np.eye(3)
    v0 = np.array([0.04, -0.03, -0.12])
    P = flight.regularised_impulse(v0, W, 0.3, 1e-3)
    v1 = v0 + W @ P
    assert abs(v1[2]) <= 1e-9 * abs(v0[2])
    assert float(v0 @ P + 0.5 * P @ (W @ P)) < 0.0
    P0 = flight.regularised_impulse(v0, W, 0.0, 1e-3)
    assert np.allclose(P0, [0.0, 0.0, -v0[2] / W[2, 2]], rtol=0, atol=1e-12 * abs(P0[2]))
    eps = 1e4
    Pv = mett.dynamics.stem.darboux_keller(v0, W, 0.3 / eps)
    Pr = flight.regularised_impulse(v0, W, 0.3, eps)
    assert np.allclose(Pr, Pv, rtol=0, atol=1e-8 * abs(Pv[2]))


def test_viscous_loss_of_contact_at_high_slip_warns():
    """μ|v_A| > 1 at the loss of contact: ViscousArtefactWarning (both ways of ending)."""
    top = TOP.replace(mu=5.0)
    state = mett.State(theta=0.5, omega3=50.0, nu_x=-2.0)
    for stop in (True, False):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            mett.simulate(top, state, t_end=0.06, stop_on_contact_loss=stop)
        assert any(issubclass(w.category, flight.ViscousArtefactWarning) for w in caught)
    with warnings.catch_warnings():
        warnings.simplefilter("error", flight.ViscousArtefactWarning)
        mett.simulate(TOP, mett.State(theta=0.1, omega3=300.0), t_end=5.0)


def test_stop_on_contact_loss_must_be_a_bool():
    with pytest.raises(TypeError, match="stop_on_contact_loss"):
        mett.simulate(TOP, mett.State(theta=0.1, omega3=155.0), t_end=0.1,
                      stop_on_contact_loss="no")  # fmt: skip


def test_a_terminal_user_event_in_flight_ends_the_run_in_the_air():
    """User events are located on the flight's dense output: a terminal one stops the run at
    the crossing the uninterrupted run's dense output has (Brent's method on both: ~1e-14 s)."""
    state = mett.State(theta=3.0, thetadot=60.0, omega3=10.0)
    free = mett.simulate(TOP, state, t_end=0.2)
    t_cross = free.crossings(3.1)[0]
    assert free.contact[np.searchsorted(free.t, t_cross)] == "none"

    def event(t, s):
        return s.theta - 3.1

    event.terminal = True
    traj = mett.simulate(TOP, state, t_end=0.2, events=[event])
    assert traj.status == "completed" and "terminal event 0" in traj.message
    assert traj.t_final == pytest.approx(t_cross, abs=1e-12)
    assert traj.t_events[0][0] == pytest.approx(t_cross, abs=1e-12)
    assert traj.contact[-1] == "none"


def test_a_painleve_inconsistent_start_ends_failed_with_a_clear_message():
    """μ = 5 s/m and a fast slip: the viscous force makes the normal force's denominator
    negative, the contact would need g_n < 0 while the free motion enters the table (ḧ(0) < 0):
    no hop, no contact. The run ends "failed" at t = 0 saying so, the start kept; the law's
    artefact is flagged."""
    top = TOP.replace(mu=5.0)
    state = mett.State(theta=1.2, omega3=50.0, nu_x=1.0)
    with pytest.warns(flight.ViscousArtefactWarning):
        traj = mett.simulate(top, state, t_end=0.3)
    assert traj.status == "failed" and "Painlevé" in traj.message
    assert traj.t.size >= 1 and traj.t_final == 0.0 and traj.t_contact_lost == 0.0


# --- hops do not accumulate (docs/theory/flight.md#hops-do-not-accumulate) ---------------------


def test_the_shared_zeno_test_finds_the_closed_form_limits_of_bouncing_sequences():
    """hybrid.geometric_tail, the one geometric-sequence test of impacts and hops: a ball dropped
    with speed v0 and restitution e bounces for Δ_k = 2 v0 e^k/g, so its bounces end at
    t_0 + 2 v0/(g (1 − e)); two interleaved sequences of the same ratio (lag 2, the ball and the
    stem) likewise. Rounding only (a few ulps of the sums)."""
    from mett.dynamics.hybrid import geometric_tail

    v0, e = 0.4, 0.55
    d = [2.0 * v0 * e**k / G for k in range(10)]
    ratio, rest = geometric_tail(d, 1, 7, 0.05)
    assert ratio == pytest.approx(e, rel=1e-13)
    assert sum(d) + rest == pytest.approx(2.0 * v0 / (G * (1.0 - e)), rel=1e-13)
    # two sequences, a Δ_a e^k and b Δ_b e^k, alternating: the limit Σ (a + b) e^k = (a + b)/(1 − e)
    a, b = 3e-3, 1e-3
    d2 = [(a if k % 2 == 0 else b) * e ** (k // 2) for k in range(10)]
    ratio, rest = geometric_tail(d2, 2, 3, 0.1)
    assert ratio == pytest.approx(e, rel=1e-13)
    assert sum(d2) + rest == pytest.approx((a + b) / (1.0 - e), rel=1e-13)
    # not shrinking, a drift (Δ_k ∝ 1/k, no finite sum), too few: none
    assert geometric_tail([1e-3] * 10, 1, 7, 0.05) is None
    assert geometric_tail([1e-3 / k for k in range(1, 13)], 1, 7, 0.05, about_mean=True) is None
    assert geometric_tail(d[:7], 1, 7, 0.05) is None


def _pulling_start(a: float) -> tuple[np.ndarray, float, float]:
    """A gliding-layout state on the table whose free motion lifts the contact point off with
    ḧ(0) = a > 0 (the contact would need the pulling force −m a/…) and h⃛(0) = j < 0: the state
    right after a landing that is followed at once by another loss of contact. Returns (y, a, j)
    with the axis tilted from L so that u_z < 0 < v_z, and |L| from ḧ(0) = −g − l Ω² u_z = a."""
    Lh = np.array([math.sin(0.3), 0.0, math.cos(0.3)])
    e = np.array([math.sin(0.9) * math.cos(0.5), math.sin(0.9) * math.sin(0.5), math.cos(0.9)])
    u = e - float(Lh @ e) * Lh
    v = np.cross(Lh, u)
    assert u[2] < 0.0 < v[2]
    Omega = math.sqrt(-(G + a) / (L * u[2]))
    y = np.array([0.0, 0.0, 0.0, 0.0, *(I1 * Omega * Lh), *e])
    return y, a, -L * Omega**3 * v[2]


@pytest.mark.parametrize("a", [1e-2, 1e-1])
def test_a_short_hop_lands_with_a_pushing_contact_force(a):
    """Why hops cannot accumulate: a hop from h = ḣ = 0 with ḧ(0) = a > 0, h⃛(0) = j < 0 lasts
    τ = 3a/|j| (the root of a τ²/2 + j τ³/6) and lands with ḧ = a + jτ = −2a: the contact then
    needs a pushing force, so contact resumes instead of a next, shorter hop. Tolerances: the
    next Taylor term, |h''''| ≤ M4 (flight.py), shifts the root by ≤ M4 τ/(4|j|) relatively and
    ḧ by ≤ 3a δ + M4 τ²/2; twice these."""
    y, a, j = _pulling_start(a)
    hop = flight.Hop(y, 0.0, BODY)
    h, h1, h2, h3 = hop.gap(0.0)
    assert h == 0.0 and h1 == 0.0
    assert h2 == pytest.approx(a, rel=1e-9) and h3 == pytest.approx(j, rel=1e-12)
    tau0 = 3.0 * a / abs(j)
    delta = hop.M4 * tau0 / (4.0 * abs(j))
    tau = hop.touchdown(1.0)
    assert tau == pytest.approx(tau0, rel=2.0 * delta)
    assert hop.gap(tau)[2] == pytest.approx(
        -2.0 * a, abs=2.0 * (3 * a * delta + hop.M4 * tau**2 / 2)
    )
    # the contact model after the (frictionless) landing: a positive normal force
    from mett.dynamics.gliding import gliding_core

    after = flight.land(hop.state(tau), float(hop.vz(tau)), (M, R, L, I1, I3, 0.0, G), False)[0]
    assert gliding_core(after.tolist(), (M, R, L, I1, I3, 0.0, G))[10] > 0.0


def test_hops_of_a_real_run_do_not_accumulate_and_stay_bounded():
    """The α = 0.4 body at ω3 = 500 rad/s from θ0 = 0.02 (viscous law) hops ~150 times in 8 s;
    once a landing needs a pulling force and the top flies again at once (handled: touchdown and
    lift-off at the same time). As the short-hop argument says, such a landing is never followed
    by another one: every hop after it ends in a contact phase of positive length, and the run
    completes without the accumulation guard."""
    top = mett.TippeTop(m=TOP.m, R=TOP.R, alpha=0.4, I1=TOP.I1, I3=TOP.I3, mu=TOP.mu)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", flight.ViscousArtefactWarning)
        traj = mett.simulate(top, mett.State(theta=0.02, omega3=500.0), t_end=8.0)
    assert traj.status == "completed", traj.message
    hops = [s for s in traj.switches if s.reason in ("lift-off", "touchdown")]
    lift = [s.t for s in hops if s.reason == "lift-off"]
    land = [s.t for s in hops if s.reason == "touchdown"]
    assert 1 < len(lift) < flight.MAX_HOPS and len(land) >= len(lift) - 1
    at_once = [k for k in range(len(land)) if k + 1 < len(lift) and lift[k + 1] == land[k]]
    assert at_once  # the case of the issue occurs in this run...
    for k in at_once:  # ...and is followed by a landing into contact, never by another one
        assert k + 2 >= len(lift) or lift[k + 2] > land[k + 1]
    _check_transitions(traj)


def _check_transitions(traj) -> None:
    """Every transition of the ball top is listed: ``contact`` is "ball" or "none" ("none"
    exactly on the flight samples), every change of it between two samples is a switch with its reason
    ("lift-off", "touchdown") located between them, and every such switch but those with no
    contact sample on one side (a touchdown followed at once by a lift-off, a start in flight)
    shows as such a change."""
    contact = np.asarray(traj.contact)
    assert set(contact) <= {"ball", "none"}
    assert np.array_equal(contact == "none", np.asarray(traj.phase) == "flight")
    hops = [s for s in traj.switches if s.reason in ("lift-off", "touchdown")]
    reason = {("ball", "none"): "lift-off", ("none", "ball"): "touchdown"}
    change = np.flatnonzero(contact[1:] != contact[:-1])
    for i in change:
        want = reason[(contact[i], contact[i + 1])]
        assert any(s.reason == want and traj.t[i] <= s.t <= traj.t[i + 1] for s in hops)
    times = [s.t for s in hops]
    unseen = {t for t in times if times.count(t) > 1} | {traj.t[0]}
    assert len(change) == sum(1 for t in times if t not in unseen)


@pytest.mark.parametrize("stop", [True, False])
def test_a_stemmed_viscous_run_warns_of_the_artefact_and_a_realistic_one_does_not(stop):
    """The stemmed top's viscous model judges its losses of contact as the ball top's does: the
    thesis body with a stem (r_s = 4 mm, l_s = 26 mm) at μ = 5 s/m sliding at 3 m/s lifts off at
    μ|v_A| > 1 (the slip of the sphere in contact, from the run's ν at the stop) and warns; at
    μ = 0.3 s/m and ω3 = 300 rad/s it lifts off near 4.96 s at μ|v_A| < 1 and does not."""
    body = TOP.replace(mu=5.0)
    top = body.with_stem(radius=0.004, distance=0.026)
    state = mett.State(theta=0.5, omega3=50.0, nu_x=-3.0)
    with pytest.warns(flight.ViscousArtefactWarning, match="mu \\|v_A\\|"):
        traj = mett.simulate(top, state, t_end=0.06, stop_on_contact_loss=stop)
    assert traj.t_contact_lost is not None
    if stop:  # the criterion, from the run's own series at the loss of contact
        assert 5.0 * math.hypot(traj.nu_x[-1], traj.nu_y[-1]) > flight.VISCOUS_ARTEFACT
    real = TOP.with_stem(radius=0.004, distance=0.026)
    with warnings.catch_warnings():
        warnings.simplefilter("error", flight.ViscousArtefactWarning)
        traj = mett.simulate(real, mett.State(theta=0.1, omega3=300.0), t_end=5.0,
                             stop_on_contact_loss=stop)  # fmt: skip
    assert traj.t_contact_lost is not None
    if stop:
        assert 0.3 * math.hypot(traj.nu_x[-1], traj.nu_y[-1]) < flight.VISCOUS_ARTEFACT


def test_the_gallery_figure_of_flights_is_drawn_and_its_run_hops_and_lands(tmp_path):
    """`mett figures` draws ball_flights through the registry (a PNG), skips it for another top
    (it shows the thesis body), and its run is what the caption says: several hops, each
    followed by contact, the last one landing for good (the run ends in contact)."""
    from mett import gallery

    (path,) = gallery.generate(tmp_path, names=["ball_flights"], animation=False, dpi=30)
    assert path.name == "ball_flights.png" and path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert "ball_flights" in gallery.skipped(mett.presets.get("cohen1977"))
    theta0, omega3 = gallery.FLIGHT_START
    run = mett.simulate(TOP, mett.State(theta=theta0, omega3=omega3), t_end=10.0)
    lifts = [s.t for s in run.switches if s.reason == "lift-off"]
    lands = [s.t for s in run.switches if s.reason == "touchdown"]
    assert run.status == "completed" and len(lifts) == len(lands) > 5
    assert run.contact[-1] == "ball" and lands[-1] < run.t[-1]
    t0, t1 = gallery.FLIGHT_WINDOW
    assert sum(t0 < t < t1 for t in lifts) >= 2  # the detail shows hops
