"""The contract every registered model keeps (one test class per model, sharing one base class).

A model declares itself once (:mod:`mett.dynamics.registry`); these tests check the declaration
against the physics: the compiled right-hand side and events equal the Python ones, the declared
conserved quantities are conserved along a run (and agree with :mod:`mett.integrals` at the start),
a State survives the round trip through the model's state vector, the normal force of a top at
rest is positive, and bad option values are refused before any work. Adding a model means adding
one subclass of :class:`ModelContract` here; ``test_every_registered_model_has_a_contract_class``
fails until it exists.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mett
from mett.dynamics import MODELS, _kernels, simulate
from mett.dynamics.registry import ACTIONS
from mett.dynamics.resistance import RollingResistance

TOP = mett.presets.get("rutstam2013")


class ModelContract:
    """Base class of the per-model contract tests (as gala's ``PotentialTestBase``).

    Subclasses set ``name`` (a registered model), ``states`` (States the model can represent, away
    from its singularities), ``options`` (keyword options of simulate) and ``bad_options``
    (``(options, exception type)`` pairs that simulate must refuse).
    """

    name: str = ""
    states: tuple[mett.State, ...] = ()
    options: dict = {}  # noqa: RUF012 - read only
    bad_options: tuple = ()
    tippe_top_integrals = True  # E, Ẽ, D, λ at the start equal mett.integrals' (l = Rα)
    conserved_rtol = 1e-8

    @property
    def model(self):
        return MODELS[self.name]

    def params(self):
        return self.model.parameters(TOP, **self.options)

    def test_registered_once_under_its_name(self):
        assert self.model.name == self.name
        assert list(MODELS).count(self.name) == 1
        for phase in self.model.phase_table():
            assert all(ev.action in ACTIONS for ev in phase.events)
            assert [ev.action for ev in phase.events].count("contact_lost") == 1

    def test_compiled_equals_python(self):
        model, p = self.model, self.params()
        rng = np.random.default_rng(3)
        for phase in model.phase_table():  # every phase of a hybrid model
            rhs, events = _kernels.compiled(model, phase.name)
            for state in self.states:
                y0 = np.asarray(model.initial(state, p), dtype=float)
                for _ in range(5):
                    # off the constraint manifold too: an unnormalised axis, a moved CM
                    y = y0 * (1.0 + 1e-3 * rng.normal(size=y0.size))
                    ref = np.asarray(phase.rhs(0.0, y, p), dtype=float)
                    out = np.empty(y.size)
                    rhs(0.0, y, np.array(p), out)
                    # the same IEEE operations in the same order: equal to the last bit
                    np.testing.assert_array_equal(out, ref)
                    g = np.empty(len(phase.events))
                    events(0.0, y, np.array(p), g)
                    np.testing.assert_array_equal(g, [ev.fn(0.0, y, p) for ev in phase.events])

    def test_declared_lengths_are_conserved_for_every_state(self):
        # Model.conserved_lengths lets the Taylor backend freeze a vector's length over a step,
        # which is exact only if the rate of the vector is perpendicular to it for every state,
        # not only on |3̂| = 1: checked off the manifold, with the vector scaled by 0.5 and 1.7
        model, p = self.model, self.params()
        rng = np.random.default_rng(11)
        for phase in model.phase_table():
            for state in self.states:
                y0 = np.asarray(model.initial(state, p), dtype=float)
                for group in model.conserved_lengths:
                    idx = list(group)
                    for stretch in (0.5, 1.7):
                        y = y0 * (1.0 + 1e-3 * rng.normal(size=y0.size))
                        y[idx] *= stretch
                        rate = np.asarray(phase.rhs(0.0, y, p), dtype=float)[idx]
                        dot = abs(float(rate @ y[idx]))
                        assert dot <= 1e-13 * np.linalg.norm(rate) * np.linalg.norm(y[idx])

    def test_derive_and_theta_take_one_parameter_set_per_column(self):
        # mett.dynamics.batch derives the series of many runs in one call, each column with its
        # own run's parameters: the result must equal the runs derived one by one, bit for bit
        model = self.model
        if model.cos_theta is None:
            pytest.skip("not run in batches (no cos_theta)")
        tops = [TOP, TOP.replace(mu=0.05, alpha=0.2), TOP.replace(m=0.03, R=0.02)]
        cols, params, single = [], [], []
        for top in tops:
            p = model.parameters(top, **self.options)
            for state in self.states:
                y0 = np.asarray(model.initial(state, p), dtype=float)
                cols.append(y0)
                params.append(p)
                single.append(model.derive(y0.reshape(-1, 1), p))
        columns = tuple(np.array(params, dtype=float).T)
        both = model.derive(np.array(cols).T, columns)
        for key, series in both.items():
            want = np.concatenate([np.broadcast_to(s[key], (1,)) for s in single])
            np.testing.assert_array_equal(np.broadcast_to(series, want.shape), want, err_msg=key)
        # and so does its cheap theta
        want = [
            float(model.theta(y.reshape(-1, 1), p)[0]) for y, p in zip(cols, params, strict=True)
        ]
        np.testing.assert_array_equal(model.theta(np.array(cols).T, columns), want)

    def test_state_round_trip(self):
        model, p = self.model, self.params()
        for state in self.states:
            y0 = np.asarray(model.initial(state, p), dtype=float)
            series = model.derive(y0.reshape(-1, 1), p)
            for field in ("theta", "thetadot", "phidot", "omega3", "nu_x", "nu_y"):
                want = getattr(state, field)
                got = float(series[field][0])
                assert got == pytest.approx(want, rel=1e-12, abs=1e-12), field
            assert float(model.theta(y0.reshape(-1, 1), p)[0]) == pytest.approx(state.theta)

    def test_integrals_at_the_start_are_those_of_mett_integrals(self):
        if not self.tippe_top_integrals:
            pytest.skip("not a tippe top with l = R alpha")
        model, p = self.model, self.params()
        for state in self.states:
            y0 = np.asarray(model.initial(state, p), dtype=float)
            s = model.derive(y0.reshape(-1, 1), p)
            assert s["lam"][0] == pytest.approx(mett.jellett(TOP, state), rel=1e-12, abs=1e-18)
            assert s["D"][0] == pytest.approx(mett.routh(TOP, state), rel=1e-12, abs=1e-18)
            assert s["E"][0] == pytest.approx(mett.energy(TOP, state), rel=1e-12)
            assert s["E_mod"][0] == pytest.approx(mett.modified_energy(TOP, state), rel=1e-12)

    def test_declared_conserved_quantities_are_conserved(self):
        for state in self.states:
            tr = simulate(TOP, state, 0.5, model=self.name, **self.options)
            assert tr.status == "completed", tr.message
            for q in self.model.conserves:
                series = getattr(tr, q)
                scale = max(abs(series[0]), 1e-300)
                drift = float(np.max(np.abs(series - series[0]))) / scale
                assert drift <= self.conserved_rtol, (q, drift)

    def test_an_undeclared_quantity_is_not_silently_conserved(self):
        # guards the test above against series that cannot change: E of a frictional model
        # (and D of a gliding one) must move when the contact point slips
        if "E" in self.model.conserves:
            pytest.skip("conserves E")
        state = self.states[-1]
        tr = simulate(TOP, state, 0.5, model=self.name, **self.options)
        assert np.ptp(tr.E) > 1e-6 * abs(tr.E[0])

    def test_normal_force_positive_at_rest(self):
        model, p = self.model, self.params()
        for theta in (0.0, 0.3, 1.5, 2.5, math.pi):
            if self.name in ("gliding-euler", "frictionless-routhian") and math.sin(theta) < 1e-3:
                continue  # outside the Euler forms' domain
            rest = mett.State(theta=theta)
            y0 = np.asarray(model.initial(rest, p), dtype=float)
            gn = float(model.normal_force(y0, p))
            # at rest the CM can only start to fall: 0 < g_n ≤ m g
            assert 0.0 < gn <= TOP.m * TOP.g * (1.0 + 1e-12), (theta, gn)

    def test_bad_options_are_refused_before_any_work(self):
        for options, exc in self.bad_options:
            with pytest.raises(exc, match=next(iter(options))):
                simulate(TOP, self.states[0], 1.0, model=self.name, **options)


_SPUN = mett.State(theta=0.1, omega3=155.0)
_TILTED = mett.State(theta=1.2, thetadot=-2.0, phidot=8.0, omega3=120.0, nu_x=0.05, nu_y=-0.1)
_SLIPPING = mett.State(theta=0.5, thetadot=1.0, omega3=120.0, nu_x=0.02)


class TestGliding(ModelContract):
    name = "gliding"
    states = (_SPUN, _TILTED)
    bad_options = (({"l": 0.01}, ValueError), ({"vertical_cm": True}, ValueError))


class TestRolling(ModelContract):
    name = "rolling"
    states = (_SPUN, mett.State(theta=1.2, thetadot=-2.0, phidot=8.0, omega3=120.0))
    conserved_rtol = 1e-9


class TestGlidingHST(ModelContract):
    name = "gliding-hst"
    states = (mett.State(theta=2.9, omega3=155.0), _TILTED)
    options = {"l": 0.004}  # noqa: RUF012
    tippe_top_integrals = False
    bad_options = (
        ({"l": -1.0}, ValueError),
        ({"l": "0.01"}, TypeError),
        ({"l": True}, TypeError),
        ({"l": math.inf}, ValueError),
    )

    def test_integrals_are_those_of_the_tip(self):
        # R = 0: λ = −l I3 ω3 and D = I3 ω3 √(γ + m l²/I3)
        model, p = self.model, self.params()
        s = model.derive(np.asarray(model.initial(_TILTED, p)).reshape(-1, 1), p)
        assert s["lam"][0] == pytest.approx(-0.004 * TOP.I3 * _TILTED.omega3, rel=1e-14)
        d = TOP.I1 / TOP.I3 + TOP.m * 0.004**2 / TOP.I3
        assert s["D"][0] == pytest.approx(TOP.I3 * _TILTED.omega3 * math.sqrt(d), rel=1e-14)


class TestCylinder(ModelContract):
    name = "cylinder"
    states = (mett.State(theta=0.4, thetadot=1.0), mett.State(theta=1.0, nu_x=0.1))


class TestGlidingEuler(ModelContract):
    name = "gliding-euler"
    states = (mett.State(theta=0.3, phidot=3.0, omega3=155.0), _TILTED)


class TestFrictionlessRouthian(ModelContract):
    name = "frictionless-routhian"
    # no friction: the CM moves freely, and ν follows from the state; a state with ν = 0
    states = (mett.State(theta=0.3, phidot=3.0, omega3=155.0), mett.State(theta=1.2, omega3=60.0))
    bad_options = (
        ({"vertical_cm": "no"}, TypeError),
        ({"vertical_cm": 0}, TypeError),
        ({"l": 0.01}, ValueError),
    )

    def test_vertical_cm_false_is_the_printed_approximation(self):
        on = self.model.parameters(TOP)
        off = self.model.parameters(TOP, vertical_cm=False)
        assert on[-1] == 1.0 and off[-1] == 0.0


class TestStemmed(ModelContract):
    # the thesis body with a stem of radius 5 mm whose centre is 25 mm from the ball's centre:
    # touchdown at arccos((0.005 - R)/0.025) = 2.21 rad, beyond both states (on the ball)
    name = "stemmed"
    states = (_SPUN, _TILTED)
    options = {"stem_radius": 0.005, "stem_distance": 0.025}  # noqa: RUF012
    bad_options = (
        ({"stem_radius": -0.005, "stem_distance": 0.025}, ValueError),
        ({"stem_distance": "0.025", "stem_radius": 0.005}, TypeError),
        ({"stem_distance": 0.01, "stem_radius": 0.005}, ValueError),  # inside the ball
        ({"stem_radius": 0.005}, ValueError),  # no distance
    )


class TestStemmedCoulomb(ModelContract):
    """The stemmed top under Coulomb friction: all four phases (ball/stem × sliding/rolling)
    compiled and checked; the states start on the ball (touchdown at 2.21 rad)."""

    name = "stemmed-coulomb"
    states = (_SPUN, _TILTED)
    options = {  # noqa: RUF012
        "friction": mett.friction.Coulomb(0.3),
        "stem_radius": 0.005,
        "stem_distance": 0.025,
    }
    _geometry = {"stem_radius": 0.005, "stem_distance": 0.025}  # noqa: RUF012
    bad_options = (
        (
            {"stem_distance": 0.01, "stem_radius": 0.005, "friction": options["friction"]},
            ValueError,
        ),
        ({"stopping_band": -1e-9, **_geometry, "friction": options["friction"]}, ValueError),
        ({"friction": mett.friction.RegularisedCoulomb(0.3, eps=1e-3), **_geometry}, ValueError),
    )

    def test_selected_by_the_law_on_a_stemmed_top(self):
        top = TOP.with_stem(radius=0.005, distance=0.025)
        tr = simulate(top, _SPUN, 0.01, friction=mett.friction.Coulomb(0.3))
        assert tr.model == self.name
        assert set(tr.contact) == {"ball"} and set(tr.phase) <= {"sliding", "rolling"}
        cc = simulate(top, _SPUN, 0.01, friction=mett.friction.Coulomb(0.3, contensou_radius=1e-3))
        assert cc.model == "stemmed-coulomb-contensou"
        assert simulate(top, _SPUN, 0.01).model == "stemmed"


class TestStemmedCoulombContensou(ModelContract):
    name = "stemmed-coulomb-contensou"
    states = (_SPUN, _SLIPPING)
    options = {  # noqa: RUF012
        "friction": mett.friction.Coulomb(0.3, contensou_radius=3e-3),
        "stem_radius": 0.005,
        "stem_distance": 0.025,
    }


class TestStemmedCoulombRegularised(ModelContract):
    """The stemmed top under the regularised Coulomb law: ball, stem and double-contact phases
    compiled and checked (the states start on the ball, touchdown at 2.21 rad)."""

    name = "stemmed-coulomb-regularised"
    states = (_SPUN, _TILTED)
    options = {  # noqa: RUF012
        "friction": mett.friction.RegularisedCoulomb(0.3, eps=1e-2),
        "stem_radius": 0.005,
        "stem_distance": 0.025,
    }
    bad_options = (
        (
            {"stem_distance": 0.01, "stem_radius": 0.005, "friction": options["friction"]},
            ValueError,
        ),
        ({"friction": mett.friction.Coulomb(0.3), "stem_radius": 0.005}, ValueError),
    )

    def test_selected_by_the_law_on_a_stemmed_top(self):
        top = TOP.with_stem(radius=0.005, distance=0.025)
        tr = simulate(top, _SPUN, 0.01, friction=self.options["friction"])
        assert tr.model == self.name and set(tr.contact) == {"ball"}


class TestCoulomb(ModelContract):
    """Exact Coulomb stick–slip (friction=Coulomb(mu)): both phases compiled and checked."""

    name = "coulomb"
    states = (_SPUN, _TILTED)  # rolls from the start; slides (and stops within 0.5 s)
    options = {"friction": mett.friction.Coulomb(0.3)}  # noqa: RUF012
    conserved_rtol = 1e-9
    bad_options = (
        ({"stopping_band": -1e-9}, ValueError),
        ({"stopping_band": "1e-9"}, TypeError),
        ({"l": 0.01}, ValueError),
    )

    def test_both_phases_are_visited(self):
        tr = simulate(TOP, _TILTED, 0.5, model=self.name, **self.options)
        assert set(tr.phase) == {"sliding", "rolling"}
        reasons = [s.reason for s in tr.switches]
        assert reasons[0] == "stop" and set(reasons) <= {"stop", "cone", "reversal"}
        for sw in tr.switches:  # the phase series agrees with the recorded switches
            # (the sample at a switch's event is the state after the switch; a stop is recorded
            # where the slip vanishes, δ/a after its event at the band)
            assert tr.phase[np.searchsorted(tr.t, sw.t_event, side="left")] == sw.after
            assert sw.t_event <= sw.t


class TestCoulombContensou(ModelContract):
    name = "coulomb-contensou"
    states = (_SPUN, _SLIPPING)
    options = {"friction": mett.friction.Coulomb(0.3, contensou_radius=3e-3)}  # noqa: RUF012

    def test_selected_by_the_law(self):
        tr = simulate(TOP, _SPUN, 0.01, friction=self.options["friction"])
        assert tr.model == self.name
        assert simulate(TOP, _SPUN, 0.01, friction=mett.friction.Coulomb(0.3)).model == "coulomb"


class TestCoulombRegularised(ModelContract):
    name = "coulomb-regularised"
    states = (_SPUN, _SLIPPING)
    options = {"friction": mett.friction.RegularisedCoulomb(0.3, eps=1e-2)}  # noqa: RUF012
    bad_options = (({"friction": mett.friction.Coulomb(0.3)}, ValueError),)


class TestRollingResistance(ModelContract):
    name = "rolling-resistance"
    states = (_SPUN, _SLIPPING)
    options = {"friction": RollingResistance(1e-4)}  # noqa: RUF012
    bad_options = (({"friction": mett.friction.Coulomb(0.3)}, ValueError),)


def test_every_registered_model_has_a_contract_class():
    covered = {cls.name for cls in ModelContract.__subclasses__()}
    assert covered == set(MODELS)


def test_an_unknown_keyword_is_a_type_error():
    with pytest.raises(TypeError, match="unexpected keyword argument 'frobnicate'"):
        simulate(TOP, _SPUN, 1.0, frobnicate=1)
