"""Integrals from a state against an independent lab-frame vector computation, and the METT identity.

The reference builds 3̂, ω, L, a, v_A in the lab frame from Euler angles (Goldstein z-x-z, docs/theory/model.md#conventions) at an arbitrary precession angle φ, and evaluates the definitions λ = −L·a,
E = ½ m|ṙ|² + ½ ω·L + m g (CM height), Ẽ = E − ½ m|ν|² + m ν·(ω×a) directly.
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import random_state, random_top

import mett

ZHAT = np.array([0.0, 0.0, 1.0])


def lab_vectors(top, s, phi):
    """Lab-frame kinematics of one state at precession angle phi (independent of mett)."""
    th = float(s.theta)
    e3 = np.array([np.sin(th) * np.sin(phi), -np.sin(th) * np.cos(phi), np.cos(th)])
    e2 = np.cross(ZHAT, e3) / np.sin(th)  # line of nodes
    e1 = np.cross(e2, e3)
    omega = -s.phidot * np.sin(th) * e1 + s.thetadot * e2 + s.omega3 * e3
    L = top.I1 * omega + (top.I3 - top.I1) * np.dot(omega, e3) * e3
    a = top.R * (top.alpha * e3 - ZHAT)
    xhat = np.array([np.sin(phi), -np.cos(phi), 0.0])
    yhat = np.array([np.cos(phi), np.sin(phi), 0.0])
    nu = s.nu_x * xhat + s.nu_y * yhat
    rdot = nu - np.cross(omega, a)
    height = top.R * (1 - top.alpha * np.cos(th))
    return dict(e3=e3, omega=omega, L=L, a=a, nu=nu, rdot=rdot, height=height, xhat=xhat)


def reference_integrals(top, s, phi):
    v = lab_vectors(top, s, phi)
    lam = -np.dot(v["L"], v["a"])
    E = (
        0.5 * top.m * v["rdot"] @ v["rdot"]
        + 0.5 * v["omega"] @ v["L"]
        + top.m * top.g * v["height"]
    )
    E_mod = E - 0.5 * top.m * v["nu"] @ v["nu"] + top.m * v["nu"] @ np.cross(v["omega"], v["a"])
    return lam, E, E_mod, v


def test_rdot_keeps_contact_and_reproduces_the_slip_formulas(rng):
    # The reference itself: ṙ·ẑ equals the rate of change of the CM height, and ν_x, ν_y match the
    # lab formulas of docs/theory/model.md#conventions (a check that the frame conventions agree).
    top = random_top(rng)
    for s in [random_state(rng, 1) for _ in range(10)]:
        s = mett.State(*(np.ravel(x)[0] for x in s.as_array()))
        phi = rng.uniform(0, 2 * np.pi)
        v = lab_vectors(top, s, phi)
        th = s.theta
        assert v["rdot"][2] == pytest.approx(top.R * top.alpha * np.sin(th) * s.thetadot, abs=1e-12)
        xd, yd = v["rdot"][:2]
        psidot = s.omega3 - s.phidot * np.cos(th)
        nu_x = (
            -top.R * s.thetadot * (1 - top.alpha * np.cos(th)) + xd * np.sin(phi) - yd * np.cos(phi)
        )
        nu_y = (
            top.R * (psidot + top.alpha * s.phidot) * np.sin(th)
            + xd * np.cos(phi)
            + yd * np.sin(phi)
        )
        assert nu_x == pytest.approx(s.nu_x, abs=1e-12)
        assert nu_y == pytest.approx(s.nu_y, abs=1e-12)


@pytest.mark.parametrize("seed", range(4))
def test_integrals_match_vector_definitions(seed):
    rng = np.random.default_rng(seed)
    top = random_top(rng)
    batch = random_state(rng, 40)
    lam, E, E_mod = (
        mett.jellett(top, batch),
        mett.energy(top, batch),
        mett.modified_energy(top, batch),
    )
    for i in range(40):
        s = mett.State(*batch.as_array()[:, i])
        ref_lam, ref_E, ref_Emod, _ = reference_integrals(top, s, rng.uniform(0, 2 * np.pi))
        assert lam[i] == pytest.approx(ref_lam, rel=1e-12, abs=1e-20)
        assert E[i] == pytest.approx(ref_E, rel=1e-12)
        assert E_mod[i] == pytest.approx(ref_Emod, rel=1e-12)


def test_routh_integral_satisfies_the_precession_identity(rng):
    # N(z) = λ√d + R D(α − z) = R I1 φ̇ (1 − z²) √d (docs/theory/mett.md#the-main-equation) links D to the vector λ and to φ̇.
    top = random_top(rng)
    batch = random_state(rng, 200)
    z = np.cos(batch.theta)
    sqd = np.sqrt(mett.d(top, z))
    lam = np.array(
        [reference_integrals(top, mett.State(*batch.as_array()[:, i]), 0.7)[0] for i in range(200)]
    )
    D = mett.routh(top, batch)
    lhs = lam * sqd + top.R * D * (top.alpha - z)
    rhs = top.R * top.I1 * batch.phidot * (1 - z**2) * sqd
    scale = np.abs(lam * sqd) + np.abs(top.R * D)
    np.testing.assert_array_less(np.abs(lhs - rhs), 1e-13 * scale)


def test_jellett_sign_convention(thesis_top):
    # docs/theory/model.md#conventions: λ > 0 for ω3 > 0 near θ = 0, and it is −L·a.
    assert mett.jellett(thesis_top, mett.State(theta=0.1, omega3=155.0)) > 0
    assert mett.jellett(thesis_top, mett.State(theta=0.1, omega3=-155.0)) < 0


def test_thesis_initial_integrals(thesis_top):
    # docs/theory/notes.md#notes: D(0) = 7.3008e-4, E(0) = 4.2153e-2 with ν(0) = 0, 4.1195e-2 with the CM at rest.
    s = mett.State(theta=0.1, omega3=155.0)
    assert mett.routh(thesis_top, s) == pytest.approx(7.3008e-4, rel=1e-4)
    assert mett.energy(thesis_top, s) == pytest.approx(4.2153e-2, rel=1e-4)
    cm = mett.State.with_cm_at_rest(thesis_top, theta=0.1, omega3=155.0)
    assert mett.energy(thesis_top, cm) == pytest.approx(4.1195e-2, rel=1e-4)
    assert cm.nu_y == pytest.approx(0.02 * 155.0 * np.sin(0.1) * (1 - 0.0), rel=1e-12)


def test_with_cm_at_rest_has_no_horizontal_cm_velocity(rng):
    top = random_top(rng)
    for _ in range(10):
        th, w3, thd, phd = (
            rng.uniform(0.1, 3.0),
            rng.normal(0, 100),
            rng.normal(0, 3),
            rng.normal(0, 9),
        )
        s = mett.State.with_cm_at_rest(top, theta=th, omega3=w3, thetadot=thd, phidot=phd)
        v = lab_vectors(top, s, rng.uniform(0, 6))
        assert np.abs(v["rdot"][:2]).max() < 1e-13


@pytest.mark.parametrize("seed", range(5))
def test_mett_identity_holds_with_modified_energy_at_gliding_states(seed):
    # Ẽ = g(z) θ̇² + V(z, D, λ) at arbitrary gliding states (docs/theory/mett.md#the-main-equation), with Ẽ, λ from the
    # independent vector reference.
    rng = np.random.default_rng(100 + seed)
    top = random_top(rng)
    batch = random_state(rng, 50)
    z = np.cos(batch.theta)
    D = mett.routh(top, batch)
    ref = [reference_integrals(top, mett.State(*batch.as_array()[:, i]), 1.3) for i in range(50)]
    lam = np.array([r[0] for r in ref])
    E = np.array([r[1] for r in ref])
    E_mod = np.array([r[2] for r in ref])
    rhs = mett.g(top, z) * batch.thetadot**2 + mett.V(top, z, D, lam)
    np.testing.assert_allclose(rhs, E_mod, rtol=1e-12)
    # The total energy E does not satisfy it while the top glides (docs/theory/notes.md#energy-vs-modified-energy).
    rel_err_E = np.abs(rhs - E) / np.abs(E)
    assert np.median(rel_err_E) > 1e-4


def test_mett_identity_with_energy_when_rolling(rng):
    top = random_top(rng)
    batch = random_state(rng, 50, gliding=False)
    z = np.cos(batch.theta)
    D, lam = mett.routh(top, batch), mett.jellett(top, batch)
    rhs = mett.g(top, z) * batch.thetadot**2 + mett.V(top, z, D, lam)
    np.testing.assert_allclose(rhs, mett.energy(top, batch), rtol=1e-12)
    np.testing.assert_array_equal(mett.energy(top, batch), mett.modified_energy(top, batch))


def test_integrals_broadcast_over_batches(thesis_top):
    s = mett.State(theta=np.linspace(0.1, 3.0, 6), omega3=np.array([[100.0], [200.0]]))
    assert s.shape == (2, 6)
    for fn in (mett.jellett, mett.routh, mett.energy, mett.modified_energy):
        out = fn(thesis_top, s)
        assert out.shape == (2, 6)
        single = fn(thesis_top, mett.State(theta=s.theta[1, 3], omega3=s.omega3[1, 3]))
        assert out[1, 3] == pytest.approx(float(single), rel=1e-15)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"theta": -0.1}, r"theta must lie in \[0, pi\]"),
        ({"theta": 3.5}, r"theta must lie in \[0, pi\]"),
        ({"theta": np.nan}, "theta must be finite"),
        ({"theta": 1.0, "omega3": np.inf}, "omega3 must be finite"),
        ({"theta": 1.0, "nu_x": np.nan}, "nu_x must be finite"),
        ({"theta": [1.0, 2.0], "omega3": [1.0, 2.0, 3.0]}, "broadcast"),
    ],
)
def test_bad_state_raises(kwargs, message):
    with pytest.raises(ValueError, match=message):
        mett.State(**kwargs)


def test_state_array_roundtrip():
    s = mett.State(theta=0.5, thetadot=1.0, phidot=2.0, omega3=3.0, nu_x=4.0, nu_y=5.0)
    assert mett.State.from_array(s.as_array()) == s
    assert s.psidot == pytest.approx(3.0 - 2.0 * np.cos(0.5))
