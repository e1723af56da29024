"""The array path of mett.separation against its per-element path (issue 5).

The public functions (band, turning_points, nutation_period, mean_precession, f) work on whole
arrays; the ``_reference_*`` functions run the same algorithms one element at a time (the
per-element path, whose brentq is scipy's and which :func:`mett.separation._brentq` transcribes),
so the two paths agree to the last bit on every case below (measured: max difference 0). The tests
ask for 1e-13 relative, the issue's target. The exact energy shift is checked against mpmath
separately.
"""

from __future__ import annotations

import math

import mpmath
import numpy as np
import pytest
from conftest import random_top
from scipy import optimize

import mett
from mett import separation as sep

_M, _R = 0.02, 0.02
BODIES = {
    "rutstam2013": mett.presets.get("rutstam2013"),
    "rutstam2012": mett.presets.get("rutstam2012"),
    "generic": mett.TippeTop(m=_M, R=_R, alpha=0.4, I1=0.8 * _M * _R**2 / 1.2, I3=_M * _R**2 / 1.2),
}
RTOL = 1e-13


def _integrals(top, theta, omega3, phidot=0.0, thetadot=0.0):
    s = mett.State(theta=theta, thetadot=thetadot, phidot=phidot, omega3=omega3)
    return mett.energy(top, s), mett.routh(top, s), mett.jellett(top, s)


def _random_integrals(top, rng, n):
    """Rolling states with θ0 ∈ (0.01, π − 0.01), |ω3| from 5 to 3e4 rad/s, φ̇0 ≠ 0 for half."""
    omega3 = np.exp(rng.uniform(np.log(5.0), np.log(3e4), n)) * rng.choice([-1.0, 1.0], n)
    phidot = rng.normal(0.0, 20.0, n) * (rng.uniform(size=n) < 0.5)
    thetadot = rng.normal(0.0, 3.0, n) * (rng.uniform(size=n) < 0.3)
    return _integrals(top, rng.uniform(0.01, np.pi - 0.01, n), omega3, phidot, thetadot)


def _special_integrals(top):
    """Near-pole, pole, near-bottom, steady, planar-rocking and tiny-spin cases of one body."""
    E, D, lam = [], [], []

    def add(e, dd, la):
        E.append(float(e))
        D.append(float(dd))
        lam.append(float(la))

    for theta in (1e-3, 0.02, np.pi - 0.02, np.pi - 1e-3):  # bands next to the poles
        for omega3 in (30.0, 300.0, 3000.0):
            add(*_integrals(top, theta, omega3, 0.0, 0.0))
            add(*_integrals(top, theta, omega3, 2.0, 0.5))
    for omega3, thetadot in ((150.0, 0.3), (150.0, 3.0), (1e4, 1.0)):  # bands reaching a pole
        _, _, la = _integrals(top, 0.0, omega3, 0.0, thetadot)
        bv = mett.boundary_values(top, la)
        add(float(bv.E0) + float(mett.g(top, 1.0)) * thetadot**2, bv.D0, la)
        if omega3 < 1e3:
            # the steady spin itself (at 1e4 rad/s E0 rounds to a band narrower than one ulp
            # of z next to the pole, where the scalar path's brentq fails: left as it was)
            add(bv.E0, bv.D0, la)
        add(float(bv.E1) + float(mett.g(top, -1.0)) * thetadot**2, bv.D1, la)
    for theta, omega3 in ((1.0, 100.0), (0.5, 3000.0), (2.2, 300.0)):  # just above the bottom
        _, dd, la = _integrals(top, theta, omega3, 5.0)
        zm = float(sep._reference_band(top, 1.0, dd, la).z_min)
        vmin = float(mett.V(top, zm, dd, la))
        for eps in (0.0, 1e-12, 1e-8, 1e-4):
            add(vmin * (1.0 + eps), dd, la)
    for theta in (0.3, 1.0, 2.5):  # planar rocking (λ = D = 0) and tiny spins
        for omega3 in (0.0, 1e-274, 1e-12, 1e-3):
            add(*_integrals(top, theta, omega3))
    return np.array(E), np.array(D), np.array(lam)


def _cases():
    rng = np.random.default_rng(20260515)
    out = []
    for name, top in BODIES.items():
        out.append((name, top, *_random_integrals(top, rng, 60)))
        out.append((f"{name}-special", top, *_special_integrals(top)))
    for i in range(6):  # random bodies, admissible (1 − α < γ < 1 + α) or not
        top = random_top(rng)
        out.append((f"random{i}", top, *_random_integrals(top, rng, 30)))
    return out


CASES = _cases()
IDS = [c[0] for c in CASES]


def _admissible(top, E, D, lam):
    kind = sep._reference_band(top, E, D, lam).kind
    keep = kind != "none"
    return E[keep], D[keep], lam[keep], kind[keep]


def _hair(b):
    """Bands with an edge or minimum a few ulps off a pole (see the test below)."""
    edges = np.stack([b.z_low, b.z_high, b.z_min])
    return np.any((np.abs(edges) < 1.0) & (1.0 - np.abs(edges) < 1e-12), axis=0)


# --- the exact shift ----------------------------------------------------------------------------


def _mp_shift(top, E, D, lam, pole=None):
    with mpmath.workdps(60):
        mp = mpmath.mpf
        val = (
            mp(E)
            - mp(D) ** 2 / (2 * mp(top.I1))
            + mp(top.m) * mp(lam) ** 2 / (2 * mp(top.I1) * mp(top.I3))
        )
        if pole is not None:
            val -= mp(top.m) * mp(top.g) * mp(top.R) * (1 - mp(top.alpha) * mp(pole))
        return float(val)


@pytest.mark.parametrize("body", list(BODIES))
def test_exact_shift_equals_mpmath(body):
    top = BODIES[body]
    rng = np.random.default_rng(7)
    E, D, lam = _random_integrals(top, rng, 400)
    # the large terms cancel completely: E' of the size of their rounding
    E_cancel = D**2 / (2 * top.I1) - top.m * lam**2 / (2 * top.I1 * top.I3)
    E = np.concatenate([E, E_cancel, rng.uniform(-1, 1, 50)])  # last: arbitrary, inadmissible
    D = np.concatenate([D, D, D[:50]])
    lam = np.concatenate([lam, lam, lam[:50]])
    poles = rng.choice([-1.0, 1.0], E.size)
    for pole in (None, poles):
        got = sep._shift(top, E, D, lam, pole)
        ref = np.array(
            [
                _mp_shift(top, e, dd, la, None if pole is None else p)
                for e, dd, la, p in zip(E, D, lam, poles, strict=True)
            ]
        )
        ulps = np.abs(got - ref) / np.spacing(np.abs(ref))
        assert np.all(ulps <= 1.0)
        assert np.mean(got == ref) > 0.99  # measured: all correctly rounded


def test_exact_shift_extreme_inputs_take_the_rational_path():
    top = BODIES["rutstam2013"]
    E = np.array([1e200, 1e-300, 0.0, 3.5, 1e-3])
    D = np.array([1e100, 1e-300, 0.0, 0.0, 1e-200])
    lam = np.array([1e98, 0.0, 0.0, 1e-320, 1e-200])
    got = sep._shift(top, E, D, lam)
    ref = [_mp_shift(top, *args) for args in zip(E, D, lam, strict=True)]
    np.testing.assert_array_equal(got, ref)
    assert sep._shifted_energy(top, 3.5, 0.0, 0.0) == 3.5


# --- the root finder ------------------------------------------------------------------------------


def test_brentq_transcription_gives_scipys_roots_bit_for_bit():
    rng = np.random.default_rng(11)
    n = 500
    c, s, p = rng.uniform(-1, 1, n), rng.uniform(1e-3, 1e3, n), 2 * rng.integers(0, 4, n) + 1

    def fun(x, k):
        return s[k] * (np.sinh(x - c[k]) + 0.3 * (x - c[k]) ** p[k])

    for xtol in (1e-300, 2e-12):
        root, ok = sep._brentq(fun, np.full(n, -1.5), np.full(n, 1.7), xtol=xtol)
        ref = [
            optimize.brentq(lambda x, i=i: fun(x, i), -1.5, 1.7, xtol=xtol, rtol=4 * sep._EPS)
            for i in range(n)
        ]
        assert ok.all()
        np.testing.assert_array_equal(root, ref)
    root, ok = sep._brentq(fun, np.full(2, 2.0), np.full(2, 3.0))  # no sign change
    assert not ok.any() and np.isnan(root).all()


# --- array path vs scalar reference ------------------------------------------------------------


@pytest.mark.parametrize(("name", "top", "E", "D", "lam"), CASES, ids=IDS)
def test_bands_equal_scalar_reference(name, top, E, D, lam):
    b, ref = sep.band(top, E, D, lam), sep._reference_band(top, E, D, lam)
    np.testing.assert_array_equal(b.kind, ref.kind)
    for field in ("z_low", "z_high", "z_min"):
        np.testing.assert_allclose(getattr(b, field), getattr(ref, field), rtol=0, atol=RTOL)
    # depth = Ẽ − V(z_min) is a difference of terms of size S (see conditioning): compare on S
    S = np.abs(E) + D * D / (2 * top.I1) + top.m * lam * lam / (2 * top.I1 * top.I3)
    assert np.all(np.abs(b.depth - ref.depth) <= RTOL * S)
    np.testing.assert_array_equal(mett.classify_motion(top, E, D, lam), ref.kind)
    # only bands ending in the layer of a pole (integrated about the pole) and wells hugging a
    # pole (classified in the pole form) leave the array path
    sol = sep.solve(top, E, D, lam, None)
    bands = [sep._reference_band(top, e, d, la) for e, d, la in zip(
        E[sol.scalar], D[sol.scalar], lam[sol.scalar], strict=True)]  # fmt: skip
    assert all(any(sep._pole_layer(b)) or 1.0 - abs(b.z_min) < sep._NEAR_POLE for b in bands)


@pytest.mark.parametrize(("name", "top", "E", "D", "lam"), CASES, ids=IDS)
def test_turning_points_periods_precession_equal_scalar_reference(name, top, E, D, lam):
    E, D, lam, kind = _admissible(top, E, D, lam)
    assert kind.size
    tp = mett.turning_points(top, E, D, lam)
    np.testing.assert_allclose(tp, sep._reference_turning_points(top, E, D, lam), rtol=0, atol=RTOL)
    # A wall or minimum a few ulps off a pole (tiny spins; D = D1 where N(-1) does not vanish to
    # rounding) without a pole reference: there the scalar path is itself that ill-conditioned -
    # one ulp of z_min (x**2 is pow() for a numpy scalar but x*x for an array) moves T by up to
    # 4e-8. Everywhere else the paths agree to the last bit or nearly (tolerance 1e-13).
    b = sep._reference_band(top, E, D, lam)
    hair = _hair(b)
    assert hair.sum() <= 10
    rtol = np.where(hair, 1e-7, RTOL)
    T = mett.nutation_period(top, E, D, lam)
    T_ref = sep._reference_nutation_period(top, E, D, lam)
    assert np.all(np.isfinite(T)) and np.all(T > 0)
    assert np.all(np.abs(T - T_ref) <= rtol * T_ref)
    mean = mett.mean_precession(top, E, D, lam)
    mean_ref = sep._reference_mean_precession(top, E, D, lam)
    np.testing.assert_array_equal(np.isnan(mean), np.isnan(mean_ref))  # NaN: steady at a pole
    # ⟨φ̇⟩ weights φ̇ = N/(R I1 (1 − z²)√d) at absolute z: in a band within 1e-6 of a pole one ulp
    # of a turning point moves it by up to 1e-7 (measured), in either path.
    edges = np.stack([b.z_low, b.z_high])
    near = np.any(1.0 - np.abs(edges) < 1e-6, axis=0)
    rtol = np.where(near | hair, 1e-6, RTOL)
    scale = np.nanmax(np.abs(mean_ref))
    ok = np.abs(mean - mean_ref) <= rtol * np.abs(mean_ref) + RTOL * scale
    assert np.all(ok | np.isnan(mean_ref))


@pytest.mark.parametrize(("name", "top", "E", "D", "lam"), CASES[:4], ids=IDS[:4])
def test_start_selection_equals_scalar_reference(name, top, E, D, lam):
    # z0 = the midpoint of the band, and the start itself for the random states.
    b = sep._reference_band(top, E, D, lam)
    live = (b.kind != "none") & ~_hair(b)
    z0 = 0.5 * (b.z_low[live] + b.z_high[live])
    args = (top, E[live], D[live], lam[live])
    np.testing.assert_allclose(
        mett.turning_points(*args, z0=z0),
        sep._reference_turning_points(*args, z0=z0),
        rtol=0,
        atol=RTOL,
    )
    np.testing.assert_allclose(
        mett.nutation_period(*args, z0=z0),
        sep._reference_nutation_period(*args, z0=z0),
        rtol=RTOL,
        atol=0,
    )


@pytest.mark.parametrize("body", list(BODIES))
def test_f_equals_scalar_reference(body):
    top = BODIES[body]
    E, D, lam = _random_integrals(top, np.random.default_rng(3), 20)
    z = np.linspace(-1.0, 1.0, 41)[:, None]
    np.testing.assert_allclose(
        mett.f(top, z, E, D, lam), sep._reference_f(top, z, E, D, lam), rtol=RTOL, atol=0
    )
    assert mett.f(top, 0.3, E[0], D[0], lam[0]) == sep._reference_f(top, 0.3, E[0], D[0], lam[0])


# --- mixed kinds, shapes, errors -----------------------------------------------------------------


def test_mixed_kinds_in_one_array():
    top = BODIES["rutstam2013"]
    _, D, lam = _integrals(top, 1.0, 100.0, 5.0)
    zm = float(sep.band(top, 1.0, D, lam).z_min)
    vmin = float(mett.V(top, zm, D, lam))
    E = vmin * np.array([1.0 + 1e-3, 1.0, 1.0 - 1e-6, 1.0 + 1e-7, 1.0, 1.0 + 0.1])
    b = mett.band(top, E, D, lam)
    assert list(b.kind) == ["nutation", "steady", "none", "nutation", "steady", "nutation"]
    assert b.kind.dtype == object
    ref = sep._reference_band(top, E, D, lam)
    for got, want in zip(b, ref, strict=True):
        np.testing.assert_array_equal(got, want)
    live = b.kind != "none"
    T = mett.nutation_period(top, E[live], D, lam)
    np.testing.assert_allclose(T, sep._reference_nutation_period(top, E[live], D, lam), rtol=RTOL)
    steady = b.kind[live] == "steady"
    np.testing.assert_array_equal(mett.turning_points(top, E[live], D, lam)[steady], [[zm, zm]] * 2)


def test_broadcasting_shapes():
    top = BODIES["rutstam2012"]
    E1, D1, lam1 = _integrals(top, 1.0, 200.0, 3.0)
    zm = float(sep.band(top, E1, D1, lam1).z_min)
    vmin = float(mett.V(top, zm, D1, lam1))
    E = vmin + (E1 - vmin) * np.array([[0.5], [1.0], [2.0]])  # (3, 1)
    D = D1 * np.array([1.0, 1.0 + 1e-6, 1.0 - 1e-6, 1.0 + 2e-6])  # (4,)
    T = mett.nutation_period(top, E, D, lam1)
    tp = mett.turning_points(top, E, D, lam1)
    b = mett.band(top, E, D, lam1)
    assert T.shape == b.kind.shape == b.depth.shape == (3, 4)
    assert tp.shape == (3, 4, 2)
    np.testing.assert_array_equal(T, sep._reference_nutation_period(top, E, D, lam1))
    np.testing.assert_array_equal(tp, sep._reference_turning_points(top, E, D, lam1))
    for idx in np.ndindex(T.shape):  # element by element through the same array path
        assert T[idx] == mett.nutation_period(top, E[idx[0], 0], D[idx[1]], lam1)
    # scalar input: floats and a (2,) array, as before
    assert isinstance(mett.nutation_period(top, E1, D1, lam1), float)
    assert isinstance(mett.mean_precession(top, E1, D1, lam1), float)
    assert mett.turning_points(top, E1, D1, lam1).shape == (2,)
    bs = mett.band(top, E1, D1, lam1)
    assert isinstance(bs.kind, str) and isinstance(bs.z_low, float)
    # an array z0 broadcast against scalar integrals
    z0 = np.full((2, 1), float(np.mean(mett.turning_points(top, E1, D1, lam1))))
    assert mett.turning_points(top, E1, D1, lam1, z0=z0).shape == (2, 1, 2)
    # empty input
    assert mett.nutation_period(top, np.array([]), D1, lam1).shape == (0,)


def _error(fn, *args, **kwargs):
    with pytest.raises(ValueError) as info:
        fn(*args, **kwargs)
    return str(info.value)


def test_first_failing_element_is_named_as_by_the_element_loop():
    top = BODIES["rutstam2013"]
    E1, D, lam = _integrals(top, 1.0, 100.0, 5.0)
    E = np.full(9, float(E1))
    E[3], E[7] = 0.0, 1e-3  # both below the well
    for name in ("turning_points", "nutation_period", "mean_precession"):
        msg = _error(getattr(mett, name), top, E, D, lam)
        assert msg == _error(getattr(sep, f"_reference_{name}"), top, E, D, lam)
        assert msg.startswith(f"(E, D, lam) = (0.0, {float(D)!r}, {float(lam)!r}) admits no motion")
    # band does not raise for "none"; with z0 every function raises the selection error
    assert list(mett.band(top, E, D, lam).kind).count("none") == 2
    z0 = np.full(9, 0.58)
    z0[5] = -0.9
    for name in ("band", "turning_points", "nutation_period"):
        msg = _error(getattr(mett, name), top, E, D, lam, z0=z0)
        assert msg == _error(getattr(sep, f"_reference_{name}"), top, E, D, lam, z0=z0)
        assert msg.startswith("no admissible motion through z0 = 0.58 for (E, D, lam) = (0.0,")


def test_elements_passed_to_the_scalar_path_give_the_same_results(monkeypatch):
    # V with several wells never occurred for physical tops in a random search (2·10⁴ draws), so
    # the hand-over is forced here: every other element goes to the scalar path.
    top = BODIES["generic"]
    E, D, lam = _special_integrals(top)
    E, D, lam, _ = _admissible(top, E, D, lam)
    keep = ~_hair(sep._reference_band(top, E, D, lam))
    E, D, lam = E[keep], D[keep], lam[keep]
    locate = sep._locate_wells

    def half(W):
        zm, single = locate(W)
        single[::2] = False
        return zm, single

    T_vec = mett.nutation_period(top, E, D, lam)
    monkeypatch.setattr(sep._api, "_locate_wells", half)  # where solve looks it up
    sol = sep.solve(top, E, D, lam, None, "period")
    assert sol.scalar[::2].all()  # forced; the others only for pole-layer bands
    assert sol.scalar.sum() <= (E.size + 1) // 2 + sum(
        any(sep._pole_layer(sep._reference_band(top, e, d, la)))
        for e, d, la in zip(E, D, lam, strict=True)
    )
    np.testing.assert_array_equal(sol.value, T_vec)
    np.testing.assert_array_equal(
        mett.turning_points(top, E, D, lam), sep._reference_turning_points(top, E, D, lam)
    )
    E_bad = E.copy()
    E_bad[2] = 0.0  # handled by the scalar path: its message too
    assert _error(mett.nutation_period, top, E_bad, D, lam) == _error(
        sep._reference_nutation_period, top, E_bad, D, lam
    )


def test_tiny_spin_period_tends_to_planar_rocking():
    # λ, D ~ 1e-278: the wall next to the pole is within one ulp of it. The period used to come
    # out NaN (divided differences across a wall that is not a root of P); now it is the rocking
    # period.
    top = mett.TippeTop(m=0.0625, R=0.03125, alpha=0.5, I1=6.103515625e-05, I3=6.103515625e-05)
    z0 = math.cos(1.0)
    T = [
        mett.nutation_period(top, *_integrals(top, 1.0, omega3), z0=z0)
        for omega3 in (0.0, 2.312762625900698e-274, 1e-12)
    ]
    assert T[1] == pytest.approx(T[0], rel=1e-11)
    assert T[2] == pytest.approx(T[0], rel=1e-11)
