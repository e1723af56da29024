"""The contract every registered friction law keeps (one test class per law, one base class).

A law is registered once (:func:`mett.friction.register`); these tests check it against its
declaration and the physics: every constructor argument is a declared parameter with a unit,
refused out of its range with a message naming it; the force opposes the slip and vanishes
without slip (where the law says so); the energy of the thesis body never rises on a short run;
and every name of :data:`mett.friction.LAWS` round-trips through the command line's
``--friction NAME:ARGS`` to the same run as the library's. Adding a law means adding one
subclass of :class:`FrictionLawContract` here; ``test_every_registered_law_has_a_contract_class``
fails until it exists.

The rolling-resistance law (:mod:`mett.dynamics.resistance`) has its own physics tests at the end:
μ_r = 0 is the "gliding" model (an independent implementation, in L_z rather than λ), and the
energy it loses is the work of its force and couple.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import mett
from mett import friction
from mett.dynamics import contact
from mett.dynamics.resistance import RollingResistance

TOP = mett.presets.get("rutstam2013")  # the thesis body, μ = 0.3 s/m
SLIPPING = mett.State(theta=0.5, thetadot=1.0, omega3=120.0, nu_x=0.02)
SPUN = mett.State(theta=0.1, omega3=155.0)
RTOL = 1e-10


class FrictionLawContract:
    """Base class of the per-law contract tests.

    Subclasses set ``law`` (the registered class), ``examples`` (instances, the first one used
    for runs), ``zero_at_zero_slip`` (the force vanishes at v_A = 0 as a function; False for a
    law whose force there is set-valued and returned as 0 only by convention).
    """

    law: type = type(None)
    examples: tuple = ()
    zero_at_zero_slip = True

    def test_registered_with_a_name(self):
        assert self.law in friction.registered()
        names = [n for n, form in friction.LAWS.items() if form.law is self.law]
        assert names, "no --friction name"
        assert all(isinstance(ex, friction.FrictionLaw) for ex in self.examples)

    def test_every_argument_is_a_declared_parameter_with_a_unit(self):
        fields = {f.name for f in dataclasses.fields(self.law)}
        declared = {p.name: p for p in self.law.params}
        assert fields == set(declared)
        assert all(p.unit for p in declared.values())

    @pytest.mark.parametrize("bad", [-1.0, math.nan, math.inf, "0.3", True])
    def test_bad_values_are_refused_naming_the_argument(self, bad):
        base = dataclasses.asdict(self.examples[0])
        for par in self.law.params:
            kw = {**base, par.name: bad}
            exc = TypeError if isinstance(bad, (str, bool)) else ValueError
            with pytest.raises(exc, match=par.name):
                self.law(**kw)
            if par.positive:  # (0, inf): zero is refused too
                with pytest.raises(ValueError, match=rf"{par.name} must lie in \(0, inf\)"):
                    self.law(**{**base, par.name: 0.0})

    def test_force_opposes_slip(self):
        rng = np.random.default_rng(7)
        v = rng.normal(scale=0.1, size=(2, 200))
        gn = rng.uniform(0.01, 1.0, size=200)
        wn = rng.normal(scale=100.0, size=200)
        for law in self.examples:
            F, M = _evaluated(law).force(v, gn, wn)
            assert F.shape == v.shape and M.shape == gn.shape
            power = np.sum(F * v, axis=0)
            assert np.all(power < 0.0)  # every example has μ > 0 and the slip is nonzero
            assert np.all(M * wn <= 0.0)  # a drilling torque resists the spin

    def test_zero_force_at_zero_slip(self):
        if not self.zero_at_zero_slip:
            pytest.skip("set-valued at zero slip")
        for law in self.examples:
            F, M = _evaluated(law).force(np.zeros((2, 3)), np.ones(3), np.zeros(3))
            np.testing.assert_array_equal(F, 0.0)
            np.testing.assert_array_equal(M, 0.0)

    def test_energy_never_rises_on_a_short_run(self):
        # Each law dissipates (its power F·v_A + M·ω ≤ 0). The energy's own error is the
        # integration error, at most rtol × the energy scale per step, summed over < 1e4 steps:
        # a rise above 1e4 rtol |E0| would be a sign error, not rounding.
        law = self.examples[0]
        tr = mett.simulate(TOP, SLIPPING, 0.2, friction=law, rtol=RTOL)
        assert tr.status == "completed", tr.message
        E = np.asarray(tr.E)
        rise = E - np.minimum.accumulate(E)
        assert float(np.max(rise)) <= 1e4 * RTOL * abs(E[0])
        assert E[-1] < E[0] - 1e4 * RTOL * abs(E[0])  # and it does dissipate

    def test_cli_round_trip(self, tmp_path, capsys):
        from mett.cli import main

        for name, form in friction.LAWS.items():
            if form.law is not self.law:
                continue
            law = self.examples[0]
            values = [getattr(law, a) if getattr(law, a) is not None else TOP.mu for a in form.args]
            want_law = form.build(*values)
            assert friction.from_args(name, values) == want_law
            spec = f"{name}:" + ",".join(repr(float(v)) for v in values)
            path = tmp_path / f"{name}.npz"
            argv = ["simulate", "--preset", "rutstam2013", "--theta0", "0.1", "--omega3", "155",
                    "--t-end", "0.02", "--friction", spec, "--out", str(path)]  # fmt: skip
            assert main(argv) == 0, capsys.readouterr().err
            got = mett.Trajectory.load(path)
            want = mett.simulate(TOP, SPUN, 0.02, friction=want_law)
            assert got.model == want.model
            np.testing.assert_array_equal(got.states, want.states)  # same process: bit for bit


def _evaluated(law):
    """``law`` with a μ to evaluate its force (a viscous μ of None is the top's)."""
    if getattr(law, "mu", 0.0) is None:
        return dataclasses.replace(law, mu=TOP.mu)
    return law


class TestViscous(FrictionLawContract):
    law = friction.Viscous
    examples = (friction.Viscous(0.3), friction.Viscous())


class TestCoulomb(FrictionLawContract):
    law = friction.Coulomb
    examples = (friction.Coulomb(0.3), friction.Coulomb(0.3, contensou_radius=5e-4))
    zero_at_zero_slip = False  # stick: any force in the cone; force() returns 0 by convention


class TestRegularisedCoulomb(FrictionLawContract):
    law = friction.RegularisedCoulomb
    examples = (friction.RegularisedCoulomb(0.3, eps=1e-3),)


class TestRollingResistance(FrictionLawContract):
    law = RollingResistance
    examples = (RollingResistance(1e-4), RollingResistance(1e-4, mu=0.1, omega_eps=1.0))

    def test_the_couple_opposes_the_rolling_velocity(self):
        rng = np.random.default_rng(5)
        w = rng.normal(scale=10.0, size=(2, 100))
        gn = rng.uniform(0.01, 1.0, size=100)
        law = RollingResistance(2e-4, omega_eps=0.1)
        M = law.torque(w, gn)
        assert np.all(np.sum(M * w, axis=0) < 0.0)
        # |M| = μ_r g_n |ω_h|/√(|ω_h|² + ω_ε²): μ_r g_n when rolling fast, 0 at ω_h = 0
        norm = np.hypot(*w)
        np.testing.assert_allclose(
            np.hypot(*M), 2e-4 * gn * norm / np.sqrt(norm**2 + 0.01), rtol=1e-14
        )
        np.testing.assert_array_equal(law.torque(np.zeros((2, 1)), [1.0]), 0.0)


def test_every_registered_law_has_a_contract_class():
    covered = {cls.law for cls in FrictionLawContract.__subclasses__()}
    assert covered == set(friction.registered())


def test_a_law_is_refused_a_name_already_taken():
    with pytest.raises(ValueError, match="'coulomb' is taken"):
        friction.register(RollingResistance, {"coulomb": ("mu_r",)})
    with pytest.raises(ValueError, match="does not declare"):
        friction.register(RollingResistance, {"x-law": ("eps",)})
    with pytest.raises(ValueError, match="not a friction law"):
        friction.register(int, {"x-law": ()})
    assert "x-law" not in friction.LAWS


def test_check_run_does_not_integrate_for_a_viscous_law(monkeypatch):
    # the law is normalised before dispatch: Viscous(mu) is the top with that mu, and checking
    # a run never runs it (no backend is called)
    from mett.dynamics import simulation

    def refuse(*args, **kwargs):
        raise AssertionError("check_run integrated")

    monkeypatch.setattr(simulation, "run_prepared", refuse)
    monkeypatch.setattr(simulation, "simulate", refuse)
    simulation.check_run(TOP, SPUN, 9.0, friction=friction.Viscous(0.1))
    prep = simulation.prepare_run(
        TOP, SPUN, 9.0, **{**simulation.SIMULATE_DEFAULTS, "friction": friction.Viscous(0.1)}
    )
    assert isinstance(prep, simulation.PreparedRun)
    assert prep.run.mdl.name == "gliding" and prep.run.params[5] == 0.1  # (m, R, l, I1, I3, μ, g)


@pytest.mark.parametrize(
    ("base", "law", "runs"),
    [
        ("gliding", friction.Viscous(0.1), "gliding"),
        ("gliding-hst", friction.Viscous(0.1), "gliding-hst"),
        ("gliding", friction.Coulomb(0.3), "coulomb"),
        ("gliding", friction.Coulomb(0.3, contensou_radius=5e-4), "coulomb-contensou"),
        ("coulomb", friction.Coulomb(0.3, contensou_radius=5e-4), "coulomb-contensou"),
        ("stemmed", friction.Coulomb(0.3), "stemmed-coulomb"),
        ("stemmed", friction.Coulomb(0.3, contensou_radius=5e-4), "stemmed-coulomb-contensou"),
        ("gliding", friction.RegularisedCoulomb(0.3, eps=1e-3), "coulomb-regularised"),
        ("stemmed", friction.RegularisedCoulomb(0.3, eps=1e-3), "stemmed-coulomb-regularised"),
        ("gliding", RollingResistance(1e-4), "rolling-resistance"),
    ],
)
def test_the_law_names_the_model_that_runs_it(base, law, runs):
    assert law.model_for(base) == runs
    assert runs in mett.dynamics.MODELS


# --- the rolling-resistance law on the thesis body ---------------------------------------------


def test_rolling_resistance_zero_is_the_gliding_model():
    # μ_r = 0: the couple vanishes and the equations are those of "gliding", integrated there in
    # the state with L_z (gliding.py's own formulas). Both runs keep a global error of a few
    # hundred rtol (relative); θ is compared at the same times through each run's dense output.
    t = np.linspace(0.0, 1.0, 51)
    ref = mett.simulate(TOP, SPUN, 1.0, rtol=RTOL, t_eval=t)
    run = mett.simulate(TOP, SPUN, 1.0, friction=RollingResistance(0.0), rtol=RTOL, t_eval=t)
    assert run.model == "rolling-resistance" and run.status == ref.status == "completed"
    for name in ("theta", "omega3", "E", "lam", "gn"):
        a, b = np.asarray(getattr(run, name)), np.asarray(getattr(ref, name))
        scale = float(np.max(np.abs(b)))
        assert float(np.max(np.abs(a - b))) <= 1e4 * RTOL * scale, name


def test_rolling_resistance_loses_the_work_of_its_force_and_couple():
    # dE/dt = F_t·v_A + M_r·ω (the normal force does no work: the contact point does not move
    # vertically). The integral of that power (trapezoid on 4001 samples over 0.5 s: step
    # h = 1.25e-4 s, relative error ≈ (h ω)²/12 ≤ 4e-5 for ω ≈ 155 rad/s) against the change of
    # E, which mett derives from the state alone.
    law = RollingResistance(1e-4)
    t = np.linspace(0.0, 0.5, 4001)
    tr = mett.simulate(TOP, SPUN, 0.5, friction=law, rtol=1e-11, t_eval=t)
    assert tr.status == "completed", tr.message
    kin = contact.kinematics(np.asarray(tr.states), tr.params)
    w, nu = kin[1], kin[4]
    Mr = law.torque(np.array([w[0], w[1]]), tr.gn)
    power_slip = tr.F_x * nu[0] + tr.F_y * nu[1]
    power_roll = Mr[0] * w[0] + Mr[1] * w[1]
    assert np.all(power_roll <= 0.0) and np.all(power_slip <= 0.0)
    work = np.trapezoid(power_slip + power_roll, t)
    loss = tr.E[-1] - tr.E[0]
    assert abs(loss - work) <= 1e-3 * abs(work)
    # and the couple's part is a real share, so the test can see its sign
    assert abs(np.trapezoid(power_roll, t)) >= 0.1 * abs(work)


def test_rolling_resistance_dissipates_faster_than_viscous_sliding_alone():
    plain = mett.simulate(TOP, SPUN, 1.0, rtol=RTOL)
    rolling = mett.simulate(TOP, SPUN, 1.0, friction=RollingResistance(1e-4), rtol=RTOL)
    assert rolling.E[-1] < plain.E[-1] - 1e4 * RTOL * abs(plain.E[0])
    assert rolling.status == plain.status == "completed"


def test_rolling_resistance_needs_its_law():
    with pytest.raises(ValueError, match="rolling-resistance' needs friction"):
        mett.simulate(TOP, SPUN, 0.1, model="rolling-resistance")
    with pytest.raises(ValueError, match="gliding-hst"):
        mett.simulate(TOP, SPUN, 0.1, model="gliding-hst", friction=RollingResistance(1e-4))


def test_rolling_resistance_runs_on_the_taylor_backend():
    # as test_taylor's test_every_model_agrees_with_dop853: the Taylor run at rtol = 1e-12 and a
    # DOP853 run at 3e-14 (its error negligible) agree within 1e-9 of the state scales
    law = RollingResistance(1e-4)
    start = mett.State(theta=0.5, omega3=155.0, phidot=3.0, nu_x=0.05)
    a = mett.simulate(TOP, start, 1.0, friction=law, backend="taylor", rtol=1e-12)
    b = mett.simulate(TOP, start, 1.0, friction=law, backend="compiled", rtol=3e-14)
    assert a.status == b.status == "completed" and a.model == "rolling-resistance"
    tt = np.linspace(0.0, 1.0, 101)
    mdl = mett.dynamics.MODELS["rolling-resistance"]
    scale = mdl.scales(a.states_at(0.0), a.params)
    err = np.abs((a.states_at(tt) - b.states_at(tt)) / scale[:, None]).max()
    assert err < 1e-9, err
