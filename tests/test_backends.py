"""The backend registry of simulate, the shared integrator status codes and the Taylor package.

Backends are objects with one protocol (``accepts``/``refusal``, ``solve`` → a piece whose dense
output truncates itself) in one registry (mett.dynamics.backends). The references here are
independent of the code under test: scipy's own ``solve_ivp`` for a backend registered by the
test, the untruncated interpolant for a truncated one, and the source text for the layering of
the Taylor package.
"""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

import mett
from mett.dynamics import MODELS, _codes, backends, dop853, simulation, taylor

TOP = mett.presets.get("rutstam2013")
THESIS = mett.State(theta=0.1, omega3=155.0)


def test_the_registry_is_what_simulate_offers():
    assert simulation.BACKENDS == ("auto", "compiled", "scipy", "taylor")
    assert tuple(backends.REGISTRY) == simulation.BACKENDS[1:]
    for name, backend in backends.REGISTRY.items():
        assert backend.name == name
    with pytest.raises(ValueError, match="already registered"):
        backends.register(backends.ScipyBackend())


def test_accepts_and_the_refusals_name_the_reason():
    gliding = MODELS["gliding"]
    compiled, scipy_, tay = (backends.REGISTRY[k] for k in ("compiled", "scipy", "taylor"))
    assert compiled.accepts(gliding, "DOP853") and tay.accepts(gliding, "DOP853")
    assert scipy_.accepts(gliding, "RK45") and not compiled.accepts(gliding, "RK45")
    assert "implements method 'DOP853' only" in compiled.refusal(gliding, "RK45")
    assert "chooses its own order" in tay.refusal(gliding, "Radau")
    python_only = dataclasses.replace(gliding, name="python-only", rhs_into=None)
    for b in (compiled, tay):
        assert "no compiled right-hand side" in b.refusal(python_only, "DOP853")
    assert scipy_.accepts(python_only, "DOP853")
    # "auto": Taylor for an analytic run, compiled DOP853 where Taylor is not exact, else scipy
    # (the choice in full: tests/test_auto.py)
    assert mett.simulate(TOP, THESIS, 0.01).backend == "taylor"
    assert mett.simulate(TOP, THESIS, 0.01, method="RK45").backend == "scipy"
    with pytest.raises(ValueError, match="implements method 'DOP853' only"):
        mett.simulate(TOP, THESIS, 0.01, backend="compiled", method="RK45")


class _PlainScipy:
    """A backend written against the protocol alone: scipy's solve_ivp, no events at all."""

    name = "plain-scipy"

    def accepts(self, model, method):
        return self.refusal(model, method) is None

    def refusal(self, model, method):
        return None if model.name == "gliding" else "gliding only"

    def solve(self, run, *, t_end, rtol, atol, max_step, events, t_eval=None, method="DOP853"):
        from scipy.integrate import solve_ivp

        run.collect = True
        res = solve_ivp(lambda t, y: run.phase.rhs(t, y, run.params), (run.t0, t_end), run.y0,
                        method=method, rtol=rtol, atol=atol, dense_output=True)  # fmt: skip
        return run.result(res.t, res.y, res.sol, "completed", "done", nfev=res.nfev, t_events=[])


def test_a_new_backend_is_one_registration(monkeypatch):
    monkeypatch.setitem(backends.REGISTRY, "plain-scipy", _PlainScipy())
    t_end = 0.5
    ours = mett.simulate(TOP, THESIS, t_end, backend="plain-scipy")
    assert ours.backend == "plain-scipy" and ours.message == "done"
    # the reference: solve_ivp called directly on the model, the same tolerances
    mdl = MODELS["gliding"]
    p = mdl.params(TOP, {})
    y0 = np.asarray(mdl.initial(THESIS, p), dtype=float)
    from scipy.integrate import solve_ivp

    ref = solve_ivp(lambda t, y: mdl.rhs(t, y, p), (0.0, t_end), y0, method="DOP853",
                    rtol=1e-10, atol=1e-10 * np.asarray(mdl.scales(y0, p)))  # fmt: skip
    assert np.array_equal(ours.t, ref.t) and np.array_equal(ours.states, ref.y)
    with pytest.raises(ValueError, match="gliding only"):
        mett.simulate(TOP, THESIS, t_end, model="rolling", backend="plain-scipy")


def _prepared(backend: str, t_end: float = 1.0):
    kw = {**simulation.SIMULATE_DEFAULTS, "backend": backend}
    return simulation.prepare_run(TOP, THESIS, t_end, **kw)


@pytest.mark.parametrize("backend", ["compiled", "taylor"])
def test_dense_outputs_truncate_themselves(backend):
    prep = _prepared(backend)
    piece = backends.REGISTRY[backend].solve(
        prep.run, t_end=prep.t_end, rtol=prep.rtol, atol=prep.atol_arr, max_step=prep.max_step,
        events=None,
    )  # fmt: skip
    assert piece.status == "completed"
    sol = piece.sol
    t_stop = 0.5 * (sol.ts[10] + sol.ts[11])  # inside a step
    cut = sol.truncate(t_stop)
    assert cut.t_max == t_stop and np.array_equal(cut.ts[:-1], sol.ts[:11])
    t = np.linspace(0.0, t_stop, 257)
    # the same polynomials up to t_stop: equal to the last bit
    assert np.array_equal(cut(t), sol(t))
    assert np.array_equal(cut.y[-1], sol(t_stop))


def test_one_set_of_status_codes():
    names = ("COMPLETED", "TERMINAL_EVENT", "STEP_TOO_SMALL", "NON_FINITE", "MAX_STEPS")
    for name in names:
        code = getattr(_codes, name)
        assert getattr(dop853, name) == code == getattr(taylor, name)
        assert _codes.IntegratorCode[name] == code
        assert (code >= 0) == (name in ("COMPLETED", "TERMINAL_EVENT"))
    assert len({getattr(_codes, n) for n in names} | {_codes.INTERRUPTED}) == len(names) + 1
    assert set(dop853.STATUS_MESSAGES) == set(taylor.STATUS_MESSAGES)


def test_single_runs_and_batches_share_one_kernel():
    mdl, ph = MODELS["gliding"], MODELS["gliding"].phase_table()[0]
    p = mdl.params(TOP, {})
    k = taylor.kernel_for(mdl, ph, 1e-10, p, n_state=10)
    assert k.order == taylor.order_for(1e-10) and k.lanes == 1
    assert k.n_events == len(ph.events)
    k4 = taylor.kernel_for(mdl, ph, 1e-10, p, 4, n_state=10, record=[mdl.cos_theta])
    assert k4.lanes == 4 and k4.n_events == len(ph.events) + 1
    # the batch path asks for the very kernel the backend's batch_kernel does
    prep = _prepared("taylor")
    assert backends.REGISTRY["taylor"].batch_kernel(prep, 4) is k4


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(encoding="utf-8"))
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names}
        elif isinstance(node, ast.ImportFrom):
            out.add("." * node.level + (node.module or ""))
    return out


def test_tracing_and_code_generation_import_no_numba():
    pkg = Path(taylor.__file__).parent
    for name in ("_trace.py", "_codegen.py"):
        found = _imports(pkg / name)
        assert not any(m.split(".")[0] in ("numba", "llvmlite") for m in found), (name, found)
        assert found <= {"__future__", "hashlib", "math", "collections.abc", "dataclasses",
                         "typing", "numpy", "numpy.typing", "._trace"}, (name, found)  # fmt: skip
